"""Tests of slam_env.envs."""
