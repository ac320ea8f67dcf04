"""Tests of slam_env.sensing."""
