"""Plain data shared by the pygame renderer and the matplotlib plots: the belief
overlay and the confidence-ellipse geometry. Pure numpy — no pygame, no matplotlib.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

#: χ²(2 dof) quantile at p = 0.95: the squared Mahalanobis radius of the 95% ellipse.
CHI2_2DOF_95 = 5.991464547107979

TrueLandmarks = Mapping[int, tuple[float, float]] | np.ndarray | None

#: RGB colours of what the pictures show, shared by the movie (:mod:`slam_env.render.renderer`)
#: and the plots (:mod:`slam_env.render.plots`), so that one thing looks the same everywhere.
PALETTE: dict[str, tuple[int, int, int]] = {
    "floor": (250, 250, 246),
    "wall": (45, 45, 45),
    "obstacle": (128, 128, 128),
    "obstacle_edge": (70, 70, 70),
    "landmark": (165, 165, 165),  # a true landmark never detected (not in the map)
    "landmark_seen": (235, 150, 20),  # a true landmark detected at least once
    "landmark_edge": (40, 40, 40),
    "truth": (40, 110, 220),  # the true robot and its path
    "truth_edge": (15, 40, 90),
    "estimate": (190, 30, 160),  # the estimated pose, its path and its 95% ellipse
    "belief_landmark": (120, 40, 200),  # landmark estimates and their 95% ellipses
    "truth_link": (150, 110, 190),  # from a landmark estimate to the truth
    "detection": (30, 170, 60),  # detections (rays in the movie, points in the map)
    "visible": (255, 215, 70),  # the sensor's visible region (drawn translucent)
    "visible_edge": (205, 165, 30),
    "label": (25, 25, 25),
}

#: Opacity (0–1) of the fill inside a 95% ellipse, in the movie and the plots.
ELLIPSE_FILL_ALPHA = 0.22

#: The legend's words for each element, the same in the movie and the plots.
LEGEND_LABELS: dict[str, str] = {
    "truth": "true trajectory",
    "estimate": "estimated trajectory",
    "estimated_pose": "estimated pose (95%)",
    "landmark": "landmarks (grey: unseen)",
    "belief_landmark": "landmark estimates (95%)",
    "detection": "detections",
    "visible": "visible region",
}


@dataclass
class BeliefOverlay:
    """What a SLAM belief looks like on screen (drawn by the renderer and the plots).

    Attributes:
        pose: (3,) estimated robot pose (x, y, θ), m and rad.
        pose_cov: (3, 3) pose covariance; only the (x, y) block is drawn.
        landmark_ids: (n,) IDs of the landmarks in the belief.
        landmark_means: (n, 2) estimated landmark positions, m.
        landmark_covs: (n, 2, 2) landmark position covariances, m².
        true_landmarks: the ground truth, to draw a thin line from each estimate to it:
            a mapping ``{id: (x, y)}``, or an (n, 2) array whose row i is the truth of
            ``landmark_ids[i]``, or ``None`` to use the drawn layout's positions.
        trail: (T, 2) past estimated positions, m, oldest first; ``None``: not drawn.
        figures: live figures of the belief to show beside the map, by name
            (``"entropy"`` nats, ``"map_rmse"`` m, ``"pose_nees"``; others are shown
            as they are); ``None``: none.
    """

    pose: np.ndarray
    pose_cov: np.ndarray
    landmark_ids: np.ndarray
    landmark_means: np.ndarray
    landmark_covs: np.ndarray
    true_landmarks: TrueLandmarks = None
    trail: np.ndarray | None = None
    figures: Mapping[str, float] | None = None

    @classmethod
    def from_state(
        cls,
        mean: np.ndarray,
        cov: np.ndarray,
        state_to_id,
        true_landmarks: TrueLandmarks = None,
    ) -> BeliefOverlay:
        """Build an overlay from an EKF-SLAM state y = [x, y, θ, m1x, m1y, …] (3+2n,),
        its covariance (3+2n, 3+2n) and the landmark IDs in state order."""
        mean = np.asarray(mean, dtype=np.float64).reshape(-1)
        cov = np.asarray(cov, dtype=np.float64)
        ids = np.asarray(state_to_id, dtype=np.int64).reshape(-1)
        n = ids.size
        if mean.size != 3 + 2 * n or cov.shape != (3 + 2 * n, 3 + 2 * n):
            raise ValueError(
                f"state of size {mean.size} and cov {cov.shape} do not match {n} landmarks"
            )
        idx = 3 + 2 * np.arange(n)
        covs = np.empty((n, 2, 2))
        covs[:, 0, 0] = cov[idx, idx]
        covs[:, 0, 1] = cov[idx, idx + 1]
        covs[:, 1, 0] = cov[idx + 1, idx]
        covs[:, 1, 1] = cov[idx + 1, idx + 1]
        return cls(
            pose=mean[:3].copy(),
            pose_cov=cov[:3, :3].copy(),
            landmark_ids=ids,
            landmark_means=mean[3:].reshape(n, 2).copy(),
            landmark_covs=covs,
            true_landmarks=true_landmarks,
        )

    def truth_for(self, fallback_ids=None, fallback_positions=None) -> np.ndarray:
        """(n, 2) true position of each belief landmark, NaN where unknown.

        Uses ``true_landmarks``; when it is ``None``, the ``fallback_ids`` /
        ``fallback_positions`` pair (e.g. the layout's) is matched by ID.
        """
        ids = np.asarray(self.landmark_ids, dtype=np.int64).reshape(-1)
        out = np.full((ids.size, 2), np.nan)
        truth = self.true_landmarks
        if truth is None:
            if fallback_ids is None or fallback_positions is None:
                return out
            pos = np.asarray(fallback_positions, dtype=np.float64).reshape(-1, 2)
            truth = {int(i): pos[k] for k, i in enumerate(np.asarray(fallback_ids).reshape(-1))}
        if isinstance(truth, Mapping):
            for k, i in enumerate(ids):
                p = truth.get(int(i))
                if p is not None:
                    out[k] = np.asarray(p, dtype=np.float64).reshape(2)
            return out
        arr = np.asarray(truth, dtype=np.float64).reshape(-1, 2)
        m = min(arr.shape[0], ids.size)
        out[:m] = arr[:m]
        return out


def chi2_radius2(n_std_or_prob: float) -> float:
    """The squared Mahalanobis radius of a 2D confidence ellipse.

    A value in (0, 1) is a probability p (χ², 2 dof: −2 ln(1 − p); 0.95 → 5.991);
    a value ≥ 1 is a number of standard deviations k (radius² k²).
    """
    v = float(n_std_or_prob)
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"n_std_or_prob must be a probability in (0, 1) or k >= 1, got {v}")
    if v < 1.0:
        return -2.0 * math.log1p(-v)
    return v * v


def ellipse_points(
    mean: np.ndarray, cov: np.ndarray, n_std_or_prob: float = 0.95, n: int = 32
) -> np.ndarray:
    """(n, 2) points on the confidence ellipse of N(mean, cov) (2D).

    ``n_std_or_prob``: a probability in (0, 1) (0.95: the 95% ellipse, radius² 5.991)
    or a number of standard deviations ≥ 1. The covariance is symmetrised and its
    negative eigenvalues (round-off in a PSD matrix) are clipped to 0, so a singular
    covariance gives a flat ellipse (a segment) or a point. A non-finite covariance
    gives n copies of the mean.
    """
    mean = np.asarray(mean, dtype=np.float64).reshape(1, 2)
    cov = np.asarray(cov, dtype=np.float64).reshape(1, 2, 2)
    return ellipses_points(mean, cov, n_std_or_prob, n)[0]


def ellipses_points(
    means: np.ndarray, covs: np.ndarray, n_std_or_prob: float = 0.95, n: int = 32
) -> np.ndarray:
    """:func:`ellipse_points` for m ellipses at once: means (m, 2), covs (m, 2, 2)
    → (m, n, 2)."""
    means = np.asarray(means, dtype=np.float64).reshape(-1, 2)
    covs = np.asarray(covs, dtype=np.float64).reshape(-1, 2, 2)
    if means.shape[0] != covs.shape[0]:
        raise ValueError(f"{means.shape[0]} means but {covs.shape[0]} covariances")
    n = int(n)
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    r = math.sqrt(chi2_radius2(n_std_or_prob))
    finite = np.all(np.isfinite(covs), axis=(1, 2))
    sym = 0.5 * (covs + np.swapaxes(covs, 1, 2))
    sym[~finite] = 0.0  # a non-finite covariance collapses to its mean
    evals, evecs = np.linalg.eigh(sym)
    # columns of ``axes``: the principal axes scaled to the ellipse's semi-axes
    axes = evecs * (r * np.sqrt(np.clip(evals, 0.0, None)))[:, None, :]
    t = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    circle = np.stack([np.cos(t), np.sin(t)], axis=1)  # (n, 2)
    return means[:, None, :] + np.einsum("kj,mij->mki", circle, axes)
