"""Tests of slam_env.render."""
