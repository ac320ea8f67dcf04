"""Training with Ray RLlib (the ``rllib`` extra): its config, its env registration, its
training loop, and RLlib checkpoints as agents."""
