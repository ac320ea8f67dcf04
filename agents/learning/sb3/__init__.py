"""Training with stable-baselines3: the step and the goal trainings, their callbacks,
timings and the adapter of the native vector env as an SB3 ``VecEnv`` (the ``agents``
extra)."""

from slam_env.extras import require

require("agents", "agents.learning.sb3")
