"""Training with stable-baselines3: the step and the goal trainings, their callbacks,
timings and the adapter of the native vector env as an SB3 ``VecEnv``."""
