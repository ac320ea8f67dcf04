"""The compiled motion of B robots of one size: the buffers of
:func:`slam_env.kernels.world.motion.drive` and its call, shared by a
:class:`~slam_env.world.pymunk_world.World` (a batch of one) and a
:class:`~slam_env.world.world_batch.WorldBatch`."""

from __future__ import annotations

import numpy as np

from slam_env.kernels.world.motion import drive
from slam_env.kernels.world.static_geometry import StaticGeometry

# Robot moves per env step: each is at most half the radius (so that the robot cannot
# tunnel) and is checked against the shapes near the robot (by the motion kernel, or a
# pymunk query in a standalone World); at the limit a step pressed into a wall costs
# about 1 ms in the envs.
MAX_MOVES_PER_STEP = 1_000
_TREE = StaticGeometry._fields.index("tree")


class Drive:
    """Drives B robots of ``radius`` (m) for ``dt`` s in at least ``substeps`` moves.

    Call with the commands ((B, 2): speed m/s, turn rate rad/s; :attr:`commands` is a
    buffer for callers without their own); the robots the kernel flags are listed for
    the caller to settle with clearance queries along ``moves[b, :counts[b]]`` from
    ``reaches[b]`` (see
    :func:`~slam_env.kernels.world.motion.drive`). The moves buffer starts at ``substeps`` rows
    and grows for fast commands up to :data:`MAX_MOVES_PER_STEP` (or
    ``substeps``, if more); a command that needs more is refused.
    """

    def __init__(self, num_envs: int, radius: float, dt: float, substeps: int) -> None:
        self.radius = float(radius)
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.max_moves = max(MAX_MOVES_PER_STEP, self.substeps)
        self.commands = np.zeros((num_envs, 2))
        self.moves = np.zeros((num_envs, self.substeps, 2))
        self.counts = np.zeros(num_envs, dtype=np.int64)
        self.reaches = np.zeros(num_envs)
        self._leaves = np.empty(0, dtype=np.int64)  # the kernel's scratch, one per tree node

    def __call__(
        self,
        poses: np.ndarray,
        disks: np.ndarray,
        commands: np.ndarray,
        active: np.ndarray,
        blocked: np.ndarray,
        geometry_fields: tuple | None,
    ) -> list[int]:
        """Move the ``active`` ((B,) bool) robots of ``poses`` ((B, 3), in place) with
        clear disks ``disks`` ((B, 3)) by ``commands`` ((B, 2) float64); ``blocked[b]``
        ((B,) bool) becomes False for each. With the worlds' static geometry
        (``geometry_fields``, else None) the kernel settles the robots itself, contacts
        included (``blocked[b]`` then set), but for a decision within round-off of a
        contact, and replaces the rows of ``disks`` of those far from every shape with
        the wider disks it found.
        Returns the flagged robots, whose positions (and contact) the caller settles.
        ``ValueError``, with nothing moved, if a speed would take more than
        :attr:`max_moves` moves."""
        leaves = self._leaves
        if geometry_fields is not None and leaves.shape[0] < geometry_fields[_TREE].shape[1]:
            leaves = self._leaves = np.empty(geometry_fields[_TREE].shape[1], dtype=np.int64)
        while True:
            flagged = drive(
                poses, disks, commands, active, self.radius, self.dt, self.substeps, self.moves,
                self.counts, self.reaches, blocked, geometry_fields, leaves,
            )  # fmt: skip
            if flagged >= 0:
                return np.flatnonzero(self.counts).tolist() if flagged else []
            self.make_room(-flagged, commands, active)  # nothing moved yet

    def make_room(self, needed: int, commands: np.ndarray, active: np.ndarray) -> None:
        """Grow :attr:`moves` to ``needed`` moves a robot, which the kernel asked for
        (refusing the call, nothing moved); ``ValueError`` if more than
        :attr:`max_moves` (the fastest of the ``active`` robots' ``commands`` named)."""
        if needed > self.max_moves:
            speeds = np.abs(commands[np.asarray(active, dtype=bool), 0])
            raise ValueError(
                f"speed {speeds.max():g} m/s is too fast for a {self.dt:g} s step: it needs "
                f"more than {self.max_moves} moves of at most half the robot's radius "
                f"({self.radius:g} m); see slam_env.world.drive.MAX_MOVES_PER_STEP"
            )
        self.moves = np.zeros((self.moves.shape[0], needed, 2))
