"""What an exploring agent keeps through an episode (agents.planners.exploration_memory)."""

from __future__ import annotations

from agents.planners.exploration_memory import StuckDetector


def test_stuck_detector_fires_only_when_commanded_motion_does_not_happen():
    det = StuckDetector(steps=4, step_length=0.2)
    assert not any(det.update((0.2 * k, 0.0), 1.0) for k in range(10))  # moving: fine
    det.clear()
    assert not any(det.update((0.0, 0.0), 0.0) for _ in range(10))  # standing still on purpose
    det.clear()
    flags = [det.update((0.0, 0.01 * k), 1.0) for k in range(5)]
    assert flags == [False, False, False, False, True]
