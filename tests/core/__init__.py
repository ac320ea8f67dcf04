"""Tests of slam_env.core."""
