"""What :meth:`slam_env.ekf.filter.EKFSLAM.update` returns: each observation's
:class:`Status`, and the :class:`UpdateResult` that holds them with the landmarks the
observations were given to and their innovations."""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

__all__ = [
    "CORRECTED",
    "DISCARDED",
    "INITIALISED",
    "REJECTED",
    "TENTATIVE",
    "Status",
    "UpdateResult",
]


class Status(enum.IntEnum):
    """What ``EKFSLAM.update`` did with one observation."""

    CORRECTED = 0  # a known landmark: the EKF correction was applied
    INITIALISED = 1  # a new landmark: added to the state from the inverse model
    REJECTED = 2  # a known landmark that failed the χ² gate (or that h cannot
    # linearise: range-bearing with the landmark estimated on the robot): not
    # applied, counted in n_rejected
    DISCARDED = 3  # the association gave it to no landmark (ambiguous, or no room)
    TENTATIVE = 4  # held as the first sighting of a possible new landmark


CORRECTED = Status.CORRECTED
INITIALISED = Status.INITIALISED
REJECTED = Status.REJECTED
DISCARDED = Status.DISCARDED
TENTATIVE = Status.TENTATIVE


# Not frozen: a frozen dataclass's __init__ writes each field through
# object.__setattr__, which made building the result about 4% of EKFSLAM's whole step
# at N = 20 (2,300 more instructions than these plain slot writes).
@dataclass(slots=True)
class UpdateResult:
    """Per-observation outcome of one ``EKFSLAM.update``, in the order given (fresh
    arrays, the caller's own).

    ``ids: (k,) int64`` the landmark each observation was given to: the ID the caller
    gave (known correspondences) or the one the association chose (``-1``: discarded,
    ``-2``: held as tentative);
    ``status: (k,) int8`` :class:`Status` codes;
    ``nis: (k,) float64`` the normalised innovation squared ``νᵀS⁻¹ν`` of each
    correction or rejection (``nan`` for an initialised landmark, and for a landmark
    the model cannot linearise, e.g. one estimated exactly on the robot).
    Sequential mode evaluates ν and S at the belief corrected by the observations
    before it; batch mode at the belief before the update (S its own 2×2 block).
    ``nearest: (k,) float64`` where the filter associates, each observation's smallest
    squared Mahalanobis distance D² to a landmark of the belief before the update
    (``inf`` with none); ``nan`` with known correspondences.
    """

    ids: np.ndarray
    status: np.ndarray
    nis: np.ndarray
    nearest: np.ndarray

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    @property
    def corrected(self) -> np.ndarray:
        """(k,) bool: observations applied as corrections."""
        return self.status == Status.CORRECTED

    @property
    def initialised(self) -> np.ndarray:
        """(k,) bool: observations that added a new landmark."""
        return self.status == Status.INITIALISED

    @property
    def rejected(self) -> np.ndarray:
        """(k,) bool: observations rejected by the gate (not applied)."""
        return self.status == Status.REJECTED

    @property
    def discarded(self) -> np.ndarray:
        """(k,) bool: observations the association gave to no landmark."""
        return self.status == Status.DISCARDED

    @property
    def tentative(self) -> np.ndarray:
        """(k,) bool: observations held as the first sighting of a new landmark."""
        return self.status == Status.TENTATIVE
