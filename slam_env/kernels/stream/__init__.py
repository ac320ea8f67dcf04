"""The raw sensor stream of B worlds: odometry readings, the landmark sensor, the
proximity scan, injected faults and the raw observation, in one step kernel."""
