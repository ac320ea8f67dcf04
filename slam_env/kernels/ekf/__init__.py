"""The batched EKF-SLAM filter: prediction, the sequential and batch corrections, new
landmarks, and data association (nearest neighbour, JCBB) with its scores."""
