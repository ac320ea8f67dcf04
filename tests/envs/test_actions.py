"""The vector env's actions: parsed for all sub-envs at once, checked where they step."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces

from slam_env.envs.actions import parse_actions

BOX = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)


def test_finite_actions_come_back_clipped_in_a_fresh_array() -> None:
    actions = np.array([[0.5, -2.0], [3.0, 0.25]])
    parsed = parse_actions(actions, BOX, 2, np.ones(2, dtype=bool))
    np.testing.assert_array_equal(parsed, [[0.5, -1.0], [1.0, 0.25]])
    assert parsed.dtype == np.float64
    assert not np.shares_memory(parsed, actions)
    np.testing.assert_array_equal(actions, [[0.5, -2.0], [3.0, 0.25]])  # left as it was


def test_a_sub_env_that_does_not_step_may_send_anything_but_a_stepping_one_may_not() -> None:
    actions = np.array([[np.nan, 0.5], [0.5, 0.5], [-np.inf, 9.0]])
    resetting = np.array([False, True, False])
    np.testing.assert_array_equal(
        parse_actions(actions, BOX, 3, resetting), [[0.0, 0.0], [0.5, 0.5], [0.0, 0.0]]
    )
    with pytest.raises(ValueError, match=r"finite; sub-envs \[0, 2\]"):
        parse_actions(actions, BOX, 3, np.ones(3, dtype=bool))
