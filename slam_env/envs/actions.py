"""Action parsing: validation, clipping and the discrete motion primitives."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

# (speed fraction, turn-rate fraction) of each discrete action, in order.
DISCRETE_PRIMITIVES: tuple[tuple[float, float], ...] = (
    (0.0, 0.0),  # 0 stop
    (1.0, 0.0),  # 1 forward
    (0.7, 0.7),  # 2 forward-left
    (0.7, -0.7),  # 3 forward-right
    (0.0, 1.0),  # 4 turn left in place
    (0.0, -1.0),  # 5 turn right in place
    (-0.5, 0.0),  # 6 reverse
)

# Float dtypes whose arrays take parse_action's fast path (a set: one hash lookup).
_FAST_DTYPES = frozenset({np.dtype(np.float32), np.dtype(np.float64)})


def parse_action(action: Any, action_space: spaces.Space) -> tuple[float, float]:
    """Turn an action into (speed fraction, turn fraction) in [−1, 1].

    Continuous actions must be two finite numbers; values outside [−1, 1] are
    clipped. Discrete actions must be an integer index of a primitive. Anything
    else raises ``ValueError``/``TypeError`` saying what was wrong.
    """
    if isinstance(action_space, spaces.Discrete):
        arr = np.asarray(action)
        if arr.shape != () or not np.issubdtype(arr.dtype, np.integer):
            raise TypeError(
                f"a discrete action must be one integer, got {action!r} "
                f"(dtype {arr.dtype}, shape {arr.shape})"
            )
        index = int(arr)
        if not 0 <= index < len(DISCRETE_PRIMITIVES):
            raise ValueError(
                f"discrete action must be in [0, {len(DISCRETE_PRIMITIVES)}), got {index}"
            )
        return DISCRETE_PRIMITIVES[index]

    if type(action) is np.ndarray and action.shape == (2,) and action.dtype in _FAST_DTYPES:
        # Fast path for what agents pass: two Python floats, no temporaries, and the
        # clip as comparisons (builtin min/max calls cost several times more).
        speed, turn = action.tolist()
        if not (math.isfinite(speed) and math.isfinite(turn)):
            raise ValueError(f"action must be finite, got {[speed, turn]}")
        speed = -1.0 if speed < -1.0 else 1.0 if speed > 1.0 else speed
        turn = -1.0 if turn < -1.0 else 1.0 if turn > 1.0 else turn
        return speed, turn
    try:
        arr = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"action must be numeric, got {type(action).__name__}: {action!r}") from exc
    if arr.shape != (2,):
        raise ValueError(f"action must have shape (2,) (speed, turn rate), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"action must be finite, got {arr.tolist()}")
    speed = min(1.0, max(-1.0, float(arr[0])))
    turn = min(1.0, max(-1.0, float(arr[1])))
    return speed, turn


# The primitives as an array, for parsing a batch of discrete actions at once.
_PRIMITIVES = np.array(DISCRETE_PRIMITIVES, dtype=np.float64)


def parse_actions(
    actions: Any, single_space: spaces.Space, num_envs: int, active: np.ndarray
) -> np.ndarray:
    """:func:`parse_action` for the actions of ``num_envs`` sub-envs at once: a fresh
    (B, 2) float64 array of the speed and turn fractions, in [−1, 1]. Only the
    ``active`` (B,) rows need be valid numbers, as only they are stepped (the others
    are being reset)."""
    if isinstance(single_space, spaces.Discrete):
        arr = np.asarray(actions)
        if arr.shape != (num_envs,) or not np.issubdtype(arr.dtype, np.integer):
            raise TypeError(
                f"discrete actions must be {num_envs} integers, got dtype {arr.dtype}, "
                f"shape {arr.shape}"
            )
        bad = active & ((arr < 0) | (arr >= len(DISCRETE_PRIMITIVES)))
        if bad.any():
            raise ValueError(
                f"discrete actions must be in [0, {len(DISCRETE_PRIMITIVES)}), got "
                f"{arr[bad].tolist()} for sub-envs {np.flatnonzero(bad).tolist()}"
            )
        return _PRIMITIVES[np.where(active, arr, 0)]
    try:
        arr = np.asarray(actions, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"actions must be numeric, got {type(actions).__name__}") from exc
    if arr.shape != (num_envs, 2):
        raise ValueError(
            f"actions must have shape ({num_envs}, 2) (speed, turn rate), got {arr.shape}"
        )
    finite_values = np.isfinite(arr)
    if finite_values.all():  # the common case: nothing to mask
        return np.clip(arr, -1.0, 1.0)
    finite = finite_values.all(axis=1)
    if not finite[active].all():
        bad = np.flatnonzero(active & ~finite)
        raise ValueError(f"actions must be finite; sub-envs {bad.tolist()} are {arr[bad]}")
    return np.clip(np.where(finite[:, None], arr, 0.0), -1.0, 1.0)
