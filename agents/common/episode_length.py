"""How long an episode is in an arena of a given size: the default world's 500 steps,
scaled with the arena's area."""

from __future__ import annotations

from slam_env.envs.registration import DEFAULT_MAX_EPISODE_STEPS

# The arena side (m) whose episodes last DEFAULT_MAX_EPISODE_STEPS; others scale with it.
REFERENCE_ARENA = 16.0


def episode_length(width: float, height: float) -> int:
    """Steps of an episode in a width × height m arena: the registered 500 at 16 m,
    in proportion to the longer side elsewhere (the time to cross the arena)."""
    return max(round(DEFAULT_MAX_EPISODE_STEPS * max(width, height) / REFERENCE_ARENA), 1)
