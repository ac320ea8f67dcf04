"""Tests of the research scripts of experiments/."""
