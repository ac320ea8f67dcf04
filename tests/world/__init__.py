"""Tests of slam_env.world."""
