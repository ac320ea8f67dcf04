"""Episodes of an agent, on a single env or on the native vector env, as records with
their per-episode metrics."""
