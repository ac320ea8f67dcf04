"""Training policies: the training config, the env a goal-choosing policy learns in,
world sampling, training metrics, PPO policies as agents, and the two engines,
stable-baselines3 (:mod:`.sb3`) and Ray RLlib (:mod:`.rllib`, an optional extra)."""
