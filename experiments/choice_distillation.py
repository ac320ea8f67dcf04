"""Whether the policy's features predict what the lookahead from the belief finds:
fit the lookahead's costs of the exploring choices, choose by the fit on held-out
episodes, and weigh those choices with the held-out labels.

    .venv/bin/python -m experiments.choice_distillation LABELS.npz [LABELS.npz ...]
        [--test-share 0.33] [--seed 0] [--epochs 200]

The labels are the choices ``experiments/choice_oracle.py --labels`` saved: the
:func:`~agents.goals.choice.choice_features` of a choice and, for each exploring choice
(the three frontier weightings), the mean steps from it to 90% of the landmarks mapped
in the worlds the lookahead drew. The episodes (their seeds) are split at random, a
share held out. Fitted on the rest: each choice's cost less that of the base's own
choice, by ridge regression (four strengths) and by a 64 × 64 tanh network (the goal
policy's shape, Adam, batches of 256; the fit after 25, 50, 100, ... ``--epochs``
passes). On the held-out choices each fit picks the choice of the lowest predicted cost
(the base's own choice where none is predicted lower).

Prints, per chooser, the held-out mean of (its pick's cost − the base's pick's cost),
steps per choice: negative means the fit would reach 90% mapped sooner than the base,
as the lookahead itself does. Standard errors treat the episodes as the independent
units. Beside them: each exploring choice taken at every choice, the pick of the
held-out labels themselves (a bound, and optimistic: the least of noisy means) and,
with two worlds or more per choice, the lookahead's own pick made on half of each
choice's worlds and weighed on the other half (unbiased).
"""

from __future__ import annotations

import argparse
import copy
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from agents.common.arguments import non_negative_int, positive_int
from agents.goals.choice import CHOICES

RIDGE_STRENGTHS = (1.0, 10.0, 100.0, 1000.0)
HIDDEN = 64
BATCH_SIZE = 256
LEARNING_RATE = 1e-3


class Split(NamedTuple):
    """One side: features, costs less the base's own choice's in each world
    ((N, worlds, choices)), episode seeds, and the choices (indices into ``CHOICES``)
    of the costs' last axis."""

    features: np.ndarray
    advantages: np.ndarray
    seeds: np.ndarray
    choices: np.ndarray


def share(text: str) -> float:
    """An argparse type: a float strictly between 0 and 1."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"must be in (0, 1), got {text}")
    return value


def load_labels(paths: Sequence[Path]) -> dict[str, np.ndarray]:
    """The arrays of every file, concatenated (``choices``: the files' common one);
    ``ValueError`` for a file that is not a label file of ``experiments/choice_oracle.py``
    or whose choices differ."""
    keys = ("features", "costs", "own", "seed")
    parts: dict[str, list[np.ndarray]] = {k: [] for k in keys}
    choices: np.ndarray | None = None
    for path in paths:
        with np.load(path) as data:
            if sorted(data.files) != sorted([*keys, "choices"]) or data["costs"].ndim != 3:
                raise ValueError(f"{path} is not a label file of experiments/choice_oracle.py")
            if choices is not None and (
                not np.array_equal(data["choices"], choices)
                or data["costs"].shape[1:] != parts["costs"][0].shape[1:]
            ):
                raise ValueError(f"{path} weighs other choices or worlds than {paths[0]}")
            choices = data["choices"]
            for k in keys:
                parts[k].append(data[k])
    return {"choices": choices, **{k: np.concatenate(v) for k, v in parts.items()}}


def advantages(costs: np.ndarray, own: np.ndarray, choices: np.ndarray) -> np.ndarray:
    """Each choice's cost (``costs``' last axis is ``choices``) less that of the base's
    own choice in the same world."""
    matches = own[:, None] == choices[None, :]
    if not matches.any(axis=1).all():
        raise ValueError("a base's own choice is not among the weighed ones")
    column = matches.argmax(axis=1)
    return costs - costs[np.arange(len(costs)), :, column][..., None]


def split(labels: dict[str, np.ndarray], test_share: float, seed: int) -> tuple[Split, Split]:
    """Train and held-out sides, the episodes (seeds) drawn at random for held-out."""
    seeds = np.unique(labels["seed"])
    if len(seeds) == 0:
        raise ValueError("the label files hold no weighed choices")
    rng = np.random.default_rng(seed)
    held = rng.choice(seeds, size=max(1, round(test_share * len(seeds))), replace=False)
    if len(held) == len(seeds):
        raise ValueError(f"{len(seeds)} episode(s) leave none to fit on; label more")
    test = np.isin(labels["seed"], held)
    adv = advantages(labels["costs"], labels["own"], labels["choices"])
    sides = [
        Split(labels["features"][m], adv[m], labels["seed"][m], labels["choices"])
        for m in (~test, test)
    ]
    return sides[0], sides[1]


def picked(predicted: np.ndarray) -> np.ndarray:
    """The choice of the lowest predicted advantage, the base's own (advantage 0)
    unless one is predicted lower."""
    lowest = predicted.argmin(axis=1)
    own_kept = predicted.min(axis=1) >= 0.0
    return np.where(own_kept, -1, lowest)


def weigh(picks: np.ndarray, side: Split, worlds: slice = slice(None)) -> tuple[float, float]:
    """Mean held-out advantage of ``picks`` (−1: the base's own choice, 0) per choice,
    over the ``worlds`` of each, and its standard error with the episodes as the
    independent units."""
    mean_advantages = side.advantages[:, worlds].mean(axis=1)
    chosen = np.where(picks < 0, 0.0, mean_advantages[np.arange(len(picks)), picks.clip(0)])
    mean = float(chosen.mean())
    sums = np.array(
        [(chosen[side.seeds == s] - mean).sum() for s in np.unique(side.seeds)], np.float64
    )
    se = math.sqrt(float((sums**2).sum())) / len(chosen) if len(sums) > 1 else math.nan
    return mean, se


def fit_ridge(train: Split, strength: float) -> Callable[[np.ndarray], np.ndarray]:
    """Ridge regression of the advantages on the features (and a constant)."""
    x = np.c_[train.features, np.ones(len(train.features))]
    penalty = strength * np.eye(x.shape[1])
    penalty[-1, -1] = 0.0  # the constant is not shrunk
    weights = np.linalg.solve(x.T @ x + penalty, x.T @ train.advantages.mean(axis=1))
    return lambda f: np.c_[f, np.ones(len(f))] @ weights


def fit_network(
    train: Split, epochs: int, seed: int, report_at: Sequence[int]
) -> dict[int, Callable[[np.ndarray], np.ndarray]]:
    """A 64 × 64 tanh network regressing the advantages (mean squared error), Adam;
    its predictions after each pass count in ``report_at``."""
    import torch

    torch.manual_seed(seed)
    features = torch.as_tensor(train.features, dtype=torch.float32)
    targets = torch.as_tensor(train.advantages.mean(axis=1), dtype=torch.float32)
    net = torch.nn.Sequential(
        torch.nn.Linear(features.shape[1], HIDDEN),
        torch.nn.Tanh(),
        torch.nn.Linear(HIDDEN, HIDDEN),
        torch.nn.Tanh(),
        torch.nn.Linear(HIDDEN, targets.shape[1]),
    )
    optimiser = torch.optim.Adam(net.parameters(), lr=LEARNING_RATE)
    fits: dict[int, Callable[[np.ndarray], np.ndarray]] = {}
    for epoch in range(1, epochs + 1):
        order = torch.randperm(len(features))
        for start in range(0, len(order), BATCH_SIZE):
            batch = order[start : start + BATCH_SIZE]
            loss = ((net(features[batch]) - targets[batch]) ** 2).mean()
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
        if epoch in report_at:
            fits[epoch] = _predictor(copy.deepcopy(net))
    return fits


def _predictor(net: Any) -> Callable[[np.ndarray], np.ndarray]:
    import torch

    def predict(features: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return net(torch.as_tensor(features, dtype=torch.float32)).numpy()

    return predict


def passes(epochs: int) -> list[int]:
    """The pass counts reported: 25, 50, 100, ... up to ``epochs``, and ``epochs``."""
    counts = [e for e in (25 * 2**k for k in range(32)) if e < epochs]
    return [*counts, epochs]


def evaluate(train: Split, test: Split, epochs: int, seed: int) -> list[tuple[str, float, float]]:
    """(chooser, held-out mean advantage per choice, standard error) for every chooser."""
    rows = []
    for k, choice in enumerate(test.choices):
        always = np.full(len(test.seeds), k)
        rows.append((f"always {CHOICES[choice].name}", *weigh(always, test)))
    best = picked(test.advantages.mean(axis=1))
    rows.append(("the held-out labels' own best (optimistic)", *weigh(best, test)))
    worlds = test.advantages.shape[1]
    if worlds > 1:  # an unbiased measure of the lookahead's own picks
        half = worlds // 2
        look = picked(test.advantages[:, :half].mean(axis=1))
        name = f"the lookahead on {half} of its worlds, weighed on the other {worlds - half}"
        rows.append((name, *weigh(look, test, slice(half, None))))
    for strength in RIDGE_STRENGTHS:
        fit = fit_ridge(train, strength)
        rows.append((f"ridge, strength {strength:g}", *weigh(picked(fit(test.features)), test)))
    for epoch, fit in fit_network(train, epochs, seed, passes(epochs)).items():
        rows.append((f"network, {epoch} passes", *weigh(picked(fit(test.features)), test)))
    return rows


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("labels", type=Path, nargs="+", help=".npz files of --labels")
    parser.add_argument("--test-share", type=share, default=0.33)
    parser.add_argument("--seed", type=non_negative_int, default=0)
    parser.add_argument("--epochs", type=positive_int, default=200)
    args = parser.parse_args(argv)
    missing = [str(p) for p in args.labels if not p.is_file()]
    if missing:
        parser.error(f"no such label file: {', '.join(missing)}")
    try:
        train, test = split(load_labels(args.labels), args.test_share, args.seed)
    except ValueError as exc:
        parser.error(str(exc))
    print(
        f"{len(train.seeds)} choices of {len(np.unique(train.seeds))} episodes fitted, "
        f"{len(test.seeds)} of {len(np.unique(test.seeds))} held out"
    )
    print("| chooser | held-out steps per choice, less the base's |\n|---|---:|")
    for name, mean, se in evaluate(train, test, args.epochs, args.seed):
        print(f"| {name} | {mean:+.2f} ± {se:.2f} |")


if __name__ == "__main__":
    main()
