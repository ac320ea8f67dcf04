"""experiments/choice_distillation.py, the command behind "Distilling the lookahead"
in docs/goal_policy.md: advantages are taken against the base's own choice in each world,
a fit keeps the base's choice unless it predicts one lower, the standard error treats
episodes as the units, and a cost the features do predict is found on held-out
episodes (so a fit that finds nothing on the lookahead's labels says something)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from experiments.choice_distillation import (
    Split,
    advantages,
    evaluate,
    load_labels,
    main,
    passes,
    picked,
    split,
    weigh,
)

CHOICES = np.array([0, 1, 2])


def test_advantages_are_against_the_own_choice_in_each_world():
    costs = np.array([[[10.0, 12.0, 7.0], [20.0, 15.0, 20.0]]])  # 1 choice, 2 worlds
    np.testing.assert_array_equal(
        advantages(costs, np.array([1]), CHOICES), [[[-2.0, 0.0, -5.0], [5.0, 0.0, 5.0]]]
    )
    with pytest.raises(ValueError, match="not among"):
        advantages(costs, np.array([4]), CHOICES)


def test_a_fit_keeps_the_own_choice_unless_it_predicts_one_lower():
    predicted = np.array([[0.0, 1.0, 2.0], [0.0, -1.0, -3.0], [0.5, 0.2, 0.1]])
    assert picked(predicted).tolist() == [-1, 2, -1]


def test_the_standard_error_counts_episodes():
    adv = np.array([[[0.0, -2.0]], [[0.0, -4.0]], [[2.0, 0.0]], [[0.0, 6.0]]])
    side = Split(np.zeros((4, 1)), adv, np.array([1, 1, 2, 2]), np.array([0, 1]))
    mean, se = weigh(np.array([1, 1, 1, 1]), side)
    assert mean == 0.0
    # Episode sums of the deviations: −6 and +6; sqrt(72) / 4 choices.
    assert se == pytest.approx(math.sqrt(72) / 4)
    # −1 keeps the base's own choice (0 steps); 0 is the first column (2 steps here).
    assert weigh(np.array([-1, -1, -1, -1]), side) == (0.0, 0.0)
    assert weigh(np.array([-1, -1, 0, -1]), side)[0] == 0.5


def synthetic(n_episodes: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Labels whose second choice saves 3 steps where the first feature is positive
    and costs 3 elsewhere, in 4 noisy worlds; the third always costs 1."""
    per = 10
    n = n_episodes * per
    features = rng.normal(size=(n, 32)).astype(np.float32)
    base = rng.uniform(20, 60, size=(n, 4, 1))
    gain = np.where(features[:, 0] > 0, -3.0, 3.0)[:, None]
    costs = np.concatenate(
        [base, base + gain[:, :, None] + rng.normal(0, 4, (n, 4, 1)), base + 1.0], axis=2
    )
    return {
        "features": features,
        "costs": costs,
        "own": np.zeros(n, np.int64),
        "seed": np.repeat(np.arange(n_episodes), per),
        "choices": CHOICES,
    }


def test_a_learnable_cost_is_found_on_held_out_episodes():
    train, test = split(synthetic(120, np.random.default_rng(0)), 0.33, seed=0)
    assert not set(train.seeds.tolist()) & set(test.seeds.tolist())
    rows = {name: (mean, se) for name, mean, se in evaluate(train, test, epochs=50, seed=0)}
    assert rows["always explore"] == (0.0, 0.0)
    assert rows["always explore_wide"][0] == pytest.approx(1.0)
    # Taking the second choice only where it saves: about −1.5 steps per choice.
    for name in ("ridge, strength 1", "network, 50 passes"):
        assert rows[name][0] < -1.0
    half = rows["the lookahead on 2 of its worlds, weighed on the other 2"][0]
    assert -1.6 < half < -0.8


def test_the_command_reads_label_files_and_refuses_others(tmp_path, capsys):
    path = tmp_path / "labels.npz"
    np.savez(path, **synthetic(12, np.random.default_rng(1)))
    main([str(path), "--epochs", "2"])
    out = capsys.readouterr().out
    assert "| network, 2 passes |" in out and out.startswith("80 choices of 8 episodes")
    other = tmp_path / "other.npz"
    np.savez(other, features=np.zeros((1, 32)))
    empty = tmp_path / "empty.npz"
    labels = synthetic(1, np.random.default_rng(1))
    np.savez(empty, **{k: v[:0] if k != "choices" else v for k, v in labels.items()})
    for args, message in [
        ([str(other)], "is not a label file"),
        ([str(tmp_path / "missing.npz")], "no such label file"),
        ([str(path), "--test-share", "1"], "must be in (0, 1), got 1"),
        ([str(empty)], "hold no weighed choices"),
    ]:
        with pytest.raises(SystemExit) as exc:
            main(args)
        assert exc.value.code == 2
        assert message in capsys.readouterr().err
    with pytest.raises(ValueError, match="other choices or worlds"):
        four = dict(np.load(path))
        np.savez(other, **{**four, "costs": four["costs"][:, :2]})
        load_labels([path, other])


def test_one_world_per_choice_has_no_halves_to_weigh(tmp_path, capsys):
    labels = synthetic(12, np.random.default_rng(2))
    labels["costs"] = labels["costs"][:, :1]  # as in hindsight
    path = tmp_path / "hindsight.npz"
    np.savez(path, **labels)
    main([str(path), "--epochs", "1"])
    out = capsys.readouterr().out
    assert "weighed on the other" not in out and "| network, 1 passes |" in out


def test_the_passes_reported():
    assert passes(200) == [25, 50, 100, 200]
    assert passes(30) == [25, 30]
    assert passes(25) == [25]
    assert passes(2) == [2]
