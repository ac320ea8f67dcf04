"""EKF-SLAM with known correspondences, pure numpy (no gymnasium, no pymunk)."""
