"""The sensors on their own, for users' own worlds (the landmark sensor with IDs, noisy
odometry), and the raw observation of the envs' stream."""
