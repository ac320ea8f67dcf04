"""Agents compared on the same seeded worlds: the evaluation (metrics, confidence
intervals, tables, plots), the evaluation suites, and the demo."""
