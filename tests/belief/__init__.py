"""Tests of slam_env.belief."""
