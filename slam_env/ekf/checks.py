"""Input checks of the filter: every bad value becomes a ``TypeError``/``ValueError``
that names what was wrong, before the filter's state is touched.

Non-real and non-numeric inputs (complex, object, strings, and bool where a number is
expected) are refused rather than cast.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from slam_env.kernels.base.integers import MAX_INTEGER, MAX_INTEGER_TEXT
from slam_env.kernels.ekf.association import MAX_NODES, MAX_PAIRINGS
from slam_env.kernels.ekf.codes import COV_LIMIT

_FLOAT64 = np.dtype(np.float64)
_INT64 = np.dtype(np.int64)


def number(value: Any, name: str) -> float:
    """A finite real scalar (Python or numpy; not bool, not complex)."""
    if isinstance(value, (bool, np.bool_, np.complexfloating)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return value


def real_array(value: Any, name: str, what: str = "an array") -> np.ndarray:
    """``value`` as a float64 array, refusing dtypes that are not real numbers
    (complex, bool, strings, objects)."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be {what} of numbers: {exc}") from None
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be {what} of numbers (real, not bool), got dtype {arr.dtype}")
    return arr.astype(np.float64, copy=False)


def float_array(value: Any, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """A finite float64 array of the given shape (a fresh copy)."""
    arr = np.array(real_array(value, name))
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    return arr


def covariance(value: Any, name: str, n: int, definite: bool) -> np.ndarray:
    """An n×n symmetric positive (semi-)definite covariance, entries at most
    :data:`~slam_env.kernels.ekf.codes.COV_LIMIT` (beyond it the filter's sums overflow)."""
    cov = float_array(value, name, (n, n))
    biggest = float(np.abs(cov).max())
    if biggest > COV_LIMIT:
        raise ValueError(
            f"{name} has an entry of {biggest:g}: covariances above {COV_LIMIT:g} overflow "
            "the filter's float64 arithmetic"
        )
    scale = max(1.0, biggest)
    if np.abs(cov - cov.T).max() > 1e-9 * scale:
        raise ValueError(f"{name} must be symmetric, got {cov.tolist()}")
    cov = 0.5 * (cov + cov.T)
    if definite:
        try:
            np.linalg.cholesky(cov)
        except np.linalg.LinAlgError:
            raise ValueError(
                f"{name} must be symmetric positive definite (a noise-free sensor makes "
                f"the innovation covariance singular), got {cov.tolist()}"
            ) from None
    elif np.linalg.eigvalsh(cov).min() < -1e-12 * scale:
        raise ValueError(f"{name} must be positive semi-definite, got {cov.tolist()}")
    return cov


def noise_params(value: Any, name: str) -> tuple[float, float, float, float]:
    """Four finite numbers ≥ 0."""
    try:
        items = list(value)
    except TypeError:
        raise TypeError(f"{name} must be a sequence of 4 numbers, got {value!r}") from None
    if len(items) != 4:
        raise ValueError(f"{name} must have 4 entries, got {len(items)}")
    out = []
    for i, item in enumerate(items):
        v = number(item, f"{name}[{i}]")
        if v < 0.0:
            raise ValueError(f"{name}[{i}] must be >= 0, got {v}")
        out.append(v)
    return out[0], out[1], out[2], out[3]


def choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    """``value`` if it is one of ``choices``, else a ``ValueError`` naming them."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {choices}, got {value!r}")
    return value


def new_landmark_sightings(value: Any) -> int:
    """The sightings a new landmark needs: 1 or 2 (bool refused)."""
    if isinstance(value, (bool, np.bool_)) or value not in (1, 2):
        raise ValueError(f"new_landmark_sightings must be 1 or 2, got {value!r}")
    return int(value)


def integer(value: Any, name: str, low: int) -> int:
    """An int in [low, :data:`~slam_env.kernels.base.integers.MAX_INTEGER`] (numpy
    integers accepted, bool refused): what the kernels hold."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if value < low:
        raise ValueError(f"{name} must be >= {low}, got {value}")
    if value > MAX_INTEGER:
        raise ValueError(
            f"{name} must be <= {MAX_INTEGER_TEXT} (what the kernels hold), got {value}"
        )
    return int(value)


def wide_pairing_scans(value: Any, data_association: str) -> int:
    """The consecutive scans a wide pairing waits for: an int >= 1 (bool refused);
    more than 1 only with ``data_association="jcbb"``."""
    value = integer(value, "wide_pairing_scans", 1)
    if value > 1 and data_association != "jcbb":
        raise ValueError(
            f"wide_pairing_scans > 1 needs data_association='jcbb', got {data_association!r}"
        )
    return value


def jcbb_pairings(pairings: int, what: str, fix: str) -> None:
    """``ValueError`` where JCBB could need more than
    :data:`~slam_env.kernels.ekf.association.MAX_PAIRINGS` pairings in one scan
    (``pairings``, as ``what`` derives it): its search would take seconds a scan."""
    if pairings > MAX_PAIRINGS:
        raise ValueError(
            f"data_association='jcbb' pairs at most {MAX_PAIRINGS} observations a scan, and "
            f"{what} = {pairings}: its search examines up to {MAX_NODES} hypotheses, each "
            f"extending the joint innovation covariance's factor in O(pairings²), seconds a "
            f"scan beyond that; {fix}, or use data_association='nearest_neighbor'"
        )


def landmark_id(value: Any) -> int:
    """One landmark ID as an int (numpy integers accepted, bool refused)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"landmark id must be an int, got {type(value).__name__}")
    return int(value)


def control_into(u: Any, row: np.ndarray, model: str) -> None:
    """Write the control u into ``row`` ((dim,) float64, the kernel's input; scratch:
    a refused control may leave part of it written). Its values are checked by the
    kernel: a non-finite one comes back as :func:`bad_control`. Real arrays of the
    right shape take a short path (a tuple of floats does not come here: EKFSLAM.predict
    passes its numbers to the kernel itself)."""
    if type(u) is np.ndarray and u.shape == row.shape and u.dtype.kind in "fiu":
        row[:] = u
        return
    arr = real_array(u, "u")
    if arr.shape != row.shape:
        raise ValueError(f"u must have shape {row.shape} for the {model} model, got {arr.shape}")
    row[:] = arr


def bad_control(u: np.ndarray) -> ValueError:
    """The error for a control the kernel refused (it is not finite)."""
    return ValueError(f"u must be finite, got {u.ravel().tolist()}")


def observations(z: Any, ids: Any) -> tuple[np.ndarray, np.ndarray]:
    """z as a float64 (k, 2) array (z itself where it is a C-contiguous, aligned,
    writable float64 array already, else a copy) and the IDs as a fresh int64 (k,) array (all
    -1 for ``None``). Both are C-contiguous, aligned and writable
    whatever the caller passed, so that they are always of one numba type (the
    filter's kernels are pinned to it). Their values (finite, IDs in range and
    distinct) are checked by the kernel before it changes anything;
    :func:`bad_observations` explains a refusal."""
    if type(z) is not np.ndarray or z.dtype is not _FLOAT64:
        z = real_array(z, "z", "a (k, 2) array")
    shape = z.shape
    if len(shape) != 2 or shape[1] != 2:
        raise ValueError(f"z must have shape (k, 2), got {shape}")
    k = shape[0]
    if not z.flags.carray:  # C-contiguous, aligned and writable: the pinned type
        z = z.copy()
    if ids is None:  # observations without IDs
        return z, np.full(k, -1, dtype=_INT64)
    if type(ids) is not np.ndarray:
        ids = np.asarray(ids)
    if ids.shape != (k,):
        raise ValueError(f"ids must have shape ({k},) to match z {shape}, got {ids.shape}")
    if ids.dtype is _INT64:
        return z, ids.copy()
    kind = ids.dtype.kind
    if kind != "i":
        if kind != "u" and k:
            raise TypeError(f"ids must be integers, got dtype {ids.dtype}")
        if kind == "u" and k and int(ids.max()) > np.iinfo(np.int64).max:
            raise ValueError(f"landmark id {int(ids.max())} is beyond the int64 range")
    return z, np.array(ids, dtype=_INT64)


def bad_observations(z: np.ndarray, ids: np.ndarray, max_landmarks: int) -> ValueError:
    """The error for observations the kernel refused (z: (k, 2), ids: (k,)): the
    first bad row or ID."""
    for row, (a, b) in enumerate(z.tolist()):
        if not (math.isfinite(a) and math.isfinite(b)):
            return ValueError(f"z must be finite; row {row} is {[a, b]}")
    id_list = ids.tolist()
    for lid in id_list:
        if lid < 0:
            return ValueError(f"landmark id {lid} is negative; ids must be in [0, {max_landmarks})")
        if lid >= max_landmarks:
            return ValueError(
                f"landmark id {lid} is beyond capacity (max_landmarks={max_landmarks})"
            )
    seen: set[int] = set()
    for lid in id_list:
        if lid in seen:
            return ValueError(f"duplicate landmark id {lid} in one update")
        seen.add(lid)
    return ValueError("the observations were refused")  # not reached: the kernel agrees
