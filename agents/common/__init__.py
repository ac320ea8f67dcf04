"""What every agent module shares: the agent interface and the random agent, the env
the agents act on, count checks, episode lengths, and vector-info rows."""
