"""Tests of agents.learning."""
