"""Tests of agents.goals."""
