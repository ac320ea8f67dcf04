"""B pymunk worlds of one config and the arrays the kernels read of them."""

from __future__ import annotations

from typing import Any

import numpy as np

from slam_env.config import EnvConfig
from slam_env.kernels.world.static_geometry import StaticGeometry, empty_geometry
from slam_env.world.drive import Drive
from slam_env.world.kidnap import kidnap_pose
from slam_env.world.layout_generators import layout_for
from slam_env.world.layouts import Layout
from slam_env.world.pymunk_world import World
from slam_env.world.static_shapes import set_world


class WorldBatch:
    """The worlds of B sub-envs: a :class:`~slam_env.world.pymunk_world.World` each (pymunk answers
    the clearance queries of the motion the kernel leaves to it) and, for the kernels,
    the true poses (B, 3) and the clear disks (B, 3) (each world's pose and disk are
    its row of these), the landmarks (B, N, 2) with their IDs (B, N) and ID order
    (B, N), and the static geometry (from which the motion kernel settles the steps,
    contacts included, with the answers pymunk's queries give: :meth:`move`).

    A fixed world (a preset or a user layout) is built once and shared by every
    sub-env; with ``preset="random"`` each reset draws a new world from the sub-env's
    generator. Each sub-env keeps one :class:`~slam_env.world.pymunk_world.World`, relaid at its
    resets (:meth:`World.relayout`: the same object, the new episode's world).
    """

    def __init__(self, config: EnvConfig, num_envs: int) -> None:
        self.config = config
        self.num_envs = num_envs
        self.fixed_layout: Layout | None = None
        if config.layout is not None or config.world.preset != "random":
            self.fixed_layout = layout_for(config, rng=None)
            ids = self.fixed_layout.landmark_ids
            if not ids:
                raise ValueError("the world has no landmarks: slam_env needs at least one")
            self.n_landmarks = len(ids)
            self.n_slots = max(ids) + 1
            self.arena_size = (self.fixed_layout.width, self.fixed_layout.height)
        else:
            self.n_landmarks = config.world.n_landmarks
            self.n_slots = config.world.n_landmarks
            self.arena_size = (config.world.width, config.world.height)
        n = self.n_landmarks
        self.worlds: list[World | None] = [None] * num_envs
        self.poses = np.zeros((num_envs, 3))
        self.before = np.zeros((num_envs, 3))  # the poses before the last move
        self.disks = np.zeros((num_envs, 3))
        self._drive = Drive(num_envs, config.robot.radius, config.dt, config.physics_substeps)
        self.landmarks = np.zeros((num_envs, n, 2))
        self.landmark_ids = np.zeros((num_envs, n), dtype=np.int64)
        self.id_order = np.tile(np.arange(n, dtype=np.int64), (num_envs, 1))
        self.geometry: StaticGeometry = empty_geometry(num_envs)
        self.geometry_fields = tuple(self.geometry)  # as the kernels take it

    def reset(self, index: int, rng: np.random.Generator) -> Layout:
        """A new episode's world for sub-env ``index`` (drawn from ``rng`` when random)."""
        cfg = self.config
        layout = self.fixed_layout or layout_for(cfg, rng=rng)
        # layout_for's worlds are valid for this robot and wall thickness.
        world = self.worlds[index]
        if world is None:
            world = World(
                layout,
                cfg.robot,
                cfg.dt,
                cfg.physics_substeps,
                cfg.world.wall_thickness,
                validated=True,
            )
            self.worlds[index] = world
            world.use_rows(self.poses[index : index + 1], self.disks[index : index + 1])
        else:
            world.relayout(layout)
        self.landmarks[index] = world.landmark_positions
        ids = world.landmark_ids
        self.landmark_ids[index] = ids
        self.id_order[index] = np.argsort(ids, kind="stable")
        self._set_geometry(index, layout)
        return layout

    def move_landmarks(
        self, index: int, layout: Layout, pose: tuple[float, float, float] | None = None
    ) -> None:
        """Make ``layout`` sub-env ``index``'s world, the robot at ``pose`` (where it
        is when None): the current world with landmarks moved (their IDs and order
        unchanged), already valid for this robot at that pose."""
        world = self.worlds[index]
        pose = world.pose if pose is None else pose
        world.relayout(layout)
        world.place(*pose)
        self.landmarks[index] = world.landmark_positions
        self._set_geometry(index, layout)

    def _set_geometry(self, index: int, layout: Layout) -> None:
        """The kernels' static geometry of sub-env ``index`` from ``layout``."""
        geometry = set_world(self.geometry, index, layout, self.config.world.wall_thickness)
        if geometry is not self.geometry:  # grown: new arrays
            self.geometry = geometry
            self.geometry_fields = tuple(geometry)

    def move(self, commands: np.ndarray, active: np.ndarray, collided: np.ndarray) -> np.ndarray:
        """Drive each ``active`` ((B,) bool) robot by its row of ``commands`` ((B, 2)
        float64, finite: speed m/s, turn rate rad/s) for one step, its collision flag
        into ``collided`` (B,). Returns the poses before the step (:attr:`before`, which
        the next call overwrites)."""
        np.copyto(self.before, self.poses)
        drive = self._drive
        for b in drive(self.poses, self.disks, commands, active, collided, self.geometry_fields):
            moves = drive.moves[b, : drive.counts[b]]
            collided[b] = self.worlds[b]._settle(moves, float(drive.reaches[b]))
        return self.before

    def __setstate__(self, state: dict[str, Any]) -> None:
        # A copy's worlds hold copies of their rows: give them the copy's own.
        self.__dict__.update(state)
        for index, world in enumerate(self.worlds):
            if world is not None:
                world.use_rows(self.poses[index : index + 1], self.disks[index : index + 1])

    def kidnap(self, index: int, rng: np.random.Generator) -> bool:
        """Carry robot ``index`` to a random free pose drawn from ``rng``; False when
        no free pose was found."""
        world = self.worlds[index]
        pose = kidnap_pose(world, rng)
        if pose is None:
            return False
        world.set_pose(*pose)  # into its row of the poses
        return True
