"""Choosing the planner's next goal: the learned goal choice and the lookahead from the
belief around it."""
