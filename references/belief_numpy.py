"""The plain Python/numpy code that the belief-side kernels replaced, kept as their
references (issue 11): the encodings, the entropy, the diagnostics and the swept-area
grid as they were computed before the kernels, one world at a time."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from slam_env.belief import metrics
from slam_env.belief.encodings import EgocentricEncoding, FullEncoding, slot_indices
from slam_env.world.frames import wrap_angle

TWO_PI = 2.0 * math.pi


def egocentric(
    enc: EgocentricEncoding,
    mean: np.ndarray,
    cov: np.ndarray,
    state_to_id: np.ndarray,
    tail: Sequence[float] = (),
) -> tuple[np.ndarray, bool]:
    """The egocentric features on Python floats, clipped if outside the bounds."""
    g = enc.geometry
    low, high = enc.space.low, enc.space.high
    ml = mean.tolist()
    dl = cov.diagonal().tolist()
    x, y, theta = ml[0], ml[1], ml[2]
    c, s = math.cos(theta), math.sin(theta)
    sqrt, tanh = math.sqrt, math.tanh
    vx, vy, vth = dl[0], dl[1], dl[2]
    feat = [0.0] * low.shape[0]
    feat[:7] = (
        x / g.width,
        y / g.height,
        c,
        s,
        tanh(sqrt(0.0 if vx < 0.0 else vx) / 1.0),
        tanh(sqrt(0.0 if vy < 0.0 else vy) / 1.0),
        tanh(sqrt(0.0 if vth < 0.0 else vth) / 0.5),
    )
    ck, sk = c / g.max_range, s / g.max_range
    bound = float(high[8]) if g.max_landmarks else 0.0
    inside = True
    for i, lid in enumerate(state_to_id.tolist()):
        row = 3 + 2 * i
        rx, ry = ml[row] - x, ml[row + 1] - y
        ex = rx * ck + ry * sk
        ey = ry * ck - rx * sk
        trace = dl[row] + dl[row + 1]
        slot = 7 + 4 * lid
        feat[slot : slot + 4] = (1.0, ex, ey, tanh(sqrt(0.0 if trace < 0.0 else trace) / 1.0))
        if not (-bound <= ex <= bound and -bound <= ey <= bound):
            inside = False
    if (
        inside
        and math.isfinite(sum(feat))
        and float(low[0]) <= feat[0] <= float(high[0])
        and float(low[1]) <= feat[1] <= float(high[1])
    ):
        return np.array(feat + list(tail), dtype=np.float32), False
    out = np.minimum(np.maximum(np.nan_to_num(np.array(feat)), low), high)
    return np.concatenate([out, tail]).astype(np.float32), True


def full(
    enc: FullEncoding, mean: np.ndarray, cov: np.ndarray, state_to_id: np.ndarray
) -> tuple[dict[str, np.ndarray], bool]:
    """The full belief slotted by ID, clipped to the bounds."""
    m = enc.geometry.max_landmarks
    dim = 3 + 2 * m
    idx = slot_indices(state_to_id)
    full_mean = np.zeros(dim)
    full_cov = np.zeros((dim, dim))
    full_mean[idx] = mean
    full_cov[np.ix_(idx, idx)] = cov
    known = np.zeros(m, dtype=np.float32)
    known[np.asarray(state_to_id, dtype=np.int64)] = 1.0
    mean_high = enc.space["mean"].high
    cov_bound = enc.space["cov"].high[0]
    clipped_mean = np.clip(np.nan_to_num(full_mean), -mean_high, mean_high)
    clipped_cov = np.clip(np.nan_to_num(full_cov), -cov_bound, cov_bound)
    clipped = not (
        np.array_equal(clipped_mean, full_mean) and np.array_equal(clipped_cov, full_cov)
    )
    obs = {
        "mean": clipped_mean.astype(np.float32),
        "cov": clipped_cov.astype(np.float32).ravel(),
        "known": known,
    }
    return obs, clipped


def belief_entropy(cov: np.ndarray, slots: int, width: float, height: float) -> float:
    """½ (D log 2πe + log det(Σ + 10⁻⁴ I) + unseen · log det(prior + 10⁻⁴ I)), LAPACK's
    Cholesky with the eigenvalue fallback."""
    floor = 1e-4
    d = cov.shape[0]
    unseen = slots - (d - 3) // 2
    prior = math.log(width * width / 12.0 + floor) + math.log(height * height / 12.0 + floor)
    log_det = metrics.log_det_psd(cov + floor * np.eye(d)) + unseen * prior
    return 0.5 * ((3 + 2 * slots) * math.log(2.0 * math.pi * math.e) + log_det)


def diagnostics(
    mean: np.ndarray, cov: np.ndarray, state_to_id: np.ndarray, pose, truth_by_id: np.ndarray
) -> dict[str, float]:
    """The per-step diagnostics as the belief wrapper computed them."""
    x, y, th = mean[:3].tolist()
    tx, ty, tth = np.asarray(pose, dtype=np.float64).tolist()
    err = [x - tx, y - ty, wrap_angle(th - tth)]
    n = state_to_id.shape[0]
    if n:
        diff = np.subtract(mean[3:], truth_by_id[state_to_id].ravel())
        map_rmse = math.sqrt(float(np.dot(diff, diff)) / n)
    else:
        map_rmse = math.nan
    pose_cov = cov[:3, :3].tolist()
    position_var = pose_cov[0][0] + pose_cov[1][1]
    return {
        "pose_error": math.hypot(err[0], err[1]),
        "heading_error": abs(err[2]),
        "map_rmse": map_rmse,
        "pose_nees": metrics.nees(np.array(err), cov[:3, :3]),
        "pose_std": 0.0 if position_var < 0.0 else math.sqrt(position_var),
    }


class CoverageGrid:
    """The swept-area grid on numpy arrays, one world, its footprint and regions
    computed afresh for each pose (the rules and float expressions of
    :class:`slam_env.belief.coverage.CoverageGrid`, which tabulates them per heading bin)."""

    DEFAULTS = {"cell": 0.5, "sectors": 8, "ring_edges": (5.0, 10.0), "heading_bins": 72}

    def __init__(self, width: float, height: float, sweep_range: float, fov: float, **options):
        self.o = {**self.DEFAULTS, **options}
        self.sweep_range, self.fov = sweep_range, fov
        cell = self.o["cell"]
        self.swept = np.zeros((math.ceil(height / cell), math.ceil(width / cell)), dtype=bool)

    @property
    def swept_fraction(self) -> float:
        return np.count_nonzero(self.swept) / self.swept.size

    def _offsets(self, x: float, y: float, theta: float):
        """Per arena cell: distance (m), bearing, bearing relative to the heading bin,
        and whether it is the robot's cell."""
        ny, nx = self.swept.shape
        cell, bins = self.o["cell"], self.o["heading_bins"]
        i = math.floor(min(max(y / cell, 0.0), ny - 1.0)) if y == y else 0
        j = math.floor(min(max(x / cell, 0.0), nx - 1.0)) if x == x else 0
        b = round(theta % TWO_PI * (bins / TWO_PI)) % bins if math.isfinite(theta) else 0
        heading = np.arange(bins)[b] * (TWO_PI / bins)
        di = np.arange(ny)[:, None] - i
        dj = np.arange(nx)[None, :] - j
        bearing = np.arctan2(di, dj)
        return np.hypot(di, dj) * cell, bearing, bearing - heading, (di == 0) & (dj == 0)

    def sweep(self, x: float, y: float, theta: float) -> int:
        dist, _, turned, own = self._offsets(x, y, theta)
        off = (turned + math.pi) % TWO_PI - math.pi
        footprint = (dist <= self.sweep_range) & ((np.abs(off) <= 0.5 * self.fov) | own)
        new = np.count_nonzero(footprint & ~self.swept)
        self.swept |= footprint
        return int(new)

    def features(self, x: float, y: float, theta: float) -> np.ndarray:
        dist, _, turned, _ = self._offsets(x, y, theta)
        sectors = self.o["sectors"]
        sector = ((turned + math.pi / sectors) % TWO_PI * (sectors / TWO_PI)).astype(np.intp)
        ring = np.searchsorted(np.asarray(self.o["ring_edges"], float), dist, side="right")
        region = ring * sectors + np.minimum(sector, sectors - 1)
        n = sectors * (len(self.o["ring_edges"]) + 1)
        total = np.bincount(region.ravel(), minlength=n)
        unswept = np.bincount(region[~self.swept], minlength=n)
        return unswept / np.maximum(total, 1)
