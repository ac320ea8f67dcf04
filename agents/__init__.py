"""Exploration agents for slam_env, their training and their evaluation.

Every agent has the stable-baselines3 predictor interface
``predict(obs, state=None, episode_start=None, deterministic=False) -> (action, state)``,
so one evaluator serves heuristic planners and trained policies alike.
"""
