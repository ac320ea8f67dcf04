"""Tests of agents.planners."""
