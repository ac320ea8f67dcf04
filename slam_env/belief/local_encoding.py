"""The ``"local"`` observation of ``slam_env/ActiveSLAM-v0``: a belief encoding whose
size does not depend on the number of landmarks, their IDs, the arena or the preset,
so that one policy runs on every world.

A policy that explores needs to know three things: how sure it is of where it is
(the robot features), what it already mapped nearby and how well (the K nearest
known landmarks, in its own frame, with their uncertainty) and where it has not looked
yet and cannot drive (the local map: unswept area, obstacles its proximity scan hit,
the arena's outside, landmark uncertainty, all turned with its heading). Positions are
measured in sensor ranges, so a policy learns "within reach" rather than metres of one
arena. The coverage features (the unswept share per sector and ring around it, the
arena's swept share) summarise the rest of the arena beyond the map.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from slam_env.belief.coverage import CoverageGrid
from slam_env.belief.encodings import HEADING_STD_SCALE, POSITION_STD_SCALE, BeliefGeometry
from slam_env.kernels.belief.belief_state import BeliefBatch
from slam_env.kernels.belief.local_map import (
    MAP_CHANNELS,
    LocalParams,
    encode_local,
    mark_scan_hits,
)

# The K nearest known landmarks in the observation.
NEAREST_LANDMARKS = 8
# The local map: MAP_SIDE × MAP_SIDE cells of MAP_CELL m, centred on the robot.
MAP_SIDE = 16
MAP_CELL = 1.0  # m: a 16 m window, three sensor ranges across at the default 5 m
# |robot-frame coordinate| / max_range beyond which a belief has diverged (the same for
# every world, so that the space is too): 100 ranges, 500 m at the default range.
RELATIVE_BOUND = 100.0
# x / width and y / height of the estimated position: ten arenas out is diverged.
POSITION_LOW, POSITION_HIGH = -10.0, 11.0

ROBOT_FEATURES = (
    "tanh(σx / 1 m)",
    "tanh(σy / 1 m)",
    "tanh(σθ / 0.5 rad)",
    "cos θ̂",
    "sin θ̂",
    "x̂ / width",
    "ŷ / height",
    "landmarks mapped / landmarks in the world",
)
_ROBOT_LOW = (0.0, 0.0, 0.0, -1.0, -1.0, POSITION_LOW, POSITION_LOW, 0.0)
_ROBOT_HIGH = (1.0, 1.0, 1.0, 1.0, 1.0, POSITION_HIGH, POSITION_HIGH, 1.0)


def local_space() -> spaces.Dict:
    """The belief part of the ``"local"`` observation space (the same for every world)."""
    k, c, s = NEAREST_LANDMARKS, MAP_CHANNELS, MAP_SIDE
    rel = np.tile(np.array([0.0, -RELATIVE_BOUND, -RELATIVE_BOUND, 0.0], np.float32), k)
    rel_high = np.tile(np.array([1.0, RELATIVE_BOUND, RELATIVE_BOUND, 1.0], np.float32), k)
    return spaces.Dict(
        {
            "robot": spaces.Box(
                np.array(_ROBOT_LOW, np.float32),
                np.array(_ROBOT_HIGH, np.float32),
                dtype=np.float32,
            ),
            "landmarks": spaces.Box(rel, rel_high, dtype=np.float32),
            "local_map": spaces.Box(0.0, 1.0, (c * s * s,), np.float32),
        }
    )


class LocalEncoding:
    """The ``"local"`` encoding of B worlds, with their memory of scan-hit obstacles.

    * ``robot`` (8,): :data:`ROBOT_FEATURES`.
    * ``landmarks`` (4K,): per row, nearest first: known (1) or padding (0), x and y
      in the estimated robot frame / max_range, tanh(√trace Σ_ii / 1 m).
    * ``local_map`` (C·S·S,): C = 4 channels of S × S cells of 1 m, row-major: the
      unswept share of the arena in the cell, an obstacle hit there by the scan (1 or
      0), the share outside the arena, and the largest 0.25 + 0.75·tanh(σ / 1 m) of a
      known landmark in it (0: none). Rows run along the robot's left, columns along
      its heading; the robot sits at the centre.

    K = :data:`NEAREST_LANDMARKS`, S = :data:`MAP_SIDE`. A belief outside the bounds
    (or with a NaN) is clipped onto them, NaN read as 0 (a non-finite pose: an empty
    map), and reported. The obstacle memory is a grid over the arena with the coverage
    grid's cells; a scan hit is placed from the *estimated* pose, as the coverage is.

    Args:
        geometry: the arena and sensor range.
        n_landmarks: landmarks in the world (for the mapped share).
        coverage: the coverage grid the map reads the swept cells of.
        beam_angles: rad, the proximity beams' directions in the robot frame.
        scan_range: m, the beams' reach.
    """

    def __init__(
        self,
        geometry: BeliefGeometry,
        n_landmarks: int,
        coverage: CoverageGrid,
        beam_angles: np.ndarray,
        scan_range: float,
    ) -> None:
        g = geometry
        self.space = local_space()
        self.coverage = coverage
        worlds = coverage.padded.shape[0]
        self.obstacles = np.zeros((worlds, coverage.ny, coverage.nx), dtype=np.bool_)
        self._beam_angles = np.ascontiguousarray(beam_angles, dtype=np.float64)
        self._scan_range = float(scan_range)
        scales = (g.width, g.height, g.max_range, POSITION_STD_SCALE, HEADING_STD_SCALE)
        self.params = LocalParams(
            np.array([*scales, float(n_landmarks), MAP_CELL], dtype=np.float64),
            coverage.cell,
            coverage.tables.pad,
            RELATIVE_BOUND,
            np.array([_ROBOT_LOW, _ROBOT_HIGH], dtype=np.float64),
        )
        # The kernel's scratch for the landmarks' distances and order, one per slot.
        self._nearest = (np.empty(0), np.empty(0, dtype=np.int64))

    def empty(self, worlds: int) -> dict[str, np.ndarray]:
        """Fresh (B, …) float32 arrays for :meth:`encode_batch` to write, by key."""
        return {
            key: np.zeros((worlds, *box.shape), dtype=np.float32)
            for key, box in self.space.spaces.items()
        }

    def reset(self, index: int) -> None:
        """Forget the obstacles world ``index`` has seen."""
        self.obstacles[index] = False

    def encode_batch(
        self,
        belief: BeliefBatch | tuple[np.ndarray, ...],
        scan: np.ndarray,
        out: dict[str, np.ndarray],
        clipped: np.ndarray,
        active: np.ndarray,
    ) -> None:
        """Mark the scan hits of ``scan`` ((B, beams) float32, the free fractions) from
        the estimated poses, then encode the beliefs of ``active`` (B,) bool into
        ``out`` (from :meth:`empty`); ``clipped`` (B,) bool. The coverage grid must
        already hold this step's sweep."""
        if self._beam_angles.size:
            mark_scan_hits(
                belief[0],  # the means
                scan,
                self._beam_angles,
                self._scan_range,
                self.coverage.cell,
                self.obstacles,
                active,
            )
        encode_local(
            *belief,
            *self.params,
            self.coverage.padded,
            self.obstacles,
            out["robot"],
            out["landmarks"],
            out["local_map"],
            clipped,
            active,
            *self._scratch(belief[3].shape[1]),
        )

    def _scratch(self, slots: int) -> tuple[np.ndarray, np.ndarray]:
        if self._nearest[0].shape[0] < max(slots, 1):
            self._nearest = (np.empty(max(slots, 1)), np.empty(max(slots, 1), dtype=np.int64))
        return self._nearest
