"""The heuristic explorers on the EKF-SLAM belief (frontier, information gain) and what
they plan with: the grid map, grid searches, the sensor's sweep, path following."""
