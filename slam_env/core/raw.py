"""The raw sensor stream of B sub-envs of one config: a step is a few kernel calls.

:class:`RawCore` is what ``slam_env/Landmarks-v0`` runs as a batch of one and its
native vector env runs for B sub-envs, so that both share every line of the model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from slam_env.config import EnvConfig
from slam_env.core.batch import BatchCore
from slam_env.core.chunks import RowThreads, rows_of
from slam_env.core.random_blocks import RandomBlocks
from slam_env.info_keys import info_row
from slam_env.kernels.base.pinning import pin
from slam_env.kernels.stream.faults import (
    CLUTTER_UNIFORMS,
    FAULT_UNIFORMS,
    KIDNAP_UNIFORM,
    FaultParams,
)
from slam_env.kernels.stream.observe import RawOutputs
from slam_env.kernels.stream.odometry import odometry_uniforms
from slam_env.kernels.stream.raw_step import raw_step
from slam_env.kernels.stream.sensing import SensorParams, scan_uniforms, sensing_scratch
from slam_env.render.renderer import Frame
from slam_env.render.visibility import visible_region
from slam_env.sensing.raw_observation import raw_observation_space
from slam_env.world.frames import robot_to_world
from slam_env.world.layouts import Layout
from slam_env.world.world_batch import WorldBatch

# Spurious detections (the outlier fault) lie at least this far away, m.
OUTLIER_MIN_RANGE = 0.5


class RawCore(BatchCore):
    """B sub-envs of ``slam_env/Landmarks-v0`` with one config, stepped together.

    Each sub-env has its own generator (:attr:`rngs`, set by :meth:`reset`), its own
    world and its own row of every array; :meth:`step` moves the robots (pymunk) and
    runs the odometry, fault, sensor and observation kernels over all of them at once.
    Results stay in the arrays until the next call: :meth:`observation` and
    :meth:`info` copy one sub-env's out, :meth:`observations` and :meth:`infos` all.
    """

    def __init__(self, config: EnvConfig, num_envs: int) -> None:
        self.config = config
        self.num_envs = num_envs
        self.worlds = WorldBatch(config, num_envs)
        self.n_landmarks = self.worlds.n_landmarks
        self.n_slots = self.worlds.n_slots
        self.arena_size = self.worlds.arena_size
        sensor = config.sensor
        self.max_detections = d = sensor.max_detections or self.n_landmarks
        self.velocity_model = config.odometry.motion_model == "velocity"
        self.control_dim = 2 if self.velocity_model else 3
        self.observation_space, self._params = raw_observation_space(
            config, self.n_slots, self.max_detections
        )
        cartesian = sensor.measurement_model == "cartesian"
        self._sensor = SensorParams(
            float(sensor.max_range),
            0.5 * float(sensor.fov),
            0.5 * sensor.fov >= math.pi,
            float(sensor.detection_prob),
            d,
            cartesian,
            float(sensor.cartesian_std if cartesian else sensor.range_std),
            float(sensor.cartesian_std if cartesian else sensor.bearing_std),
        )
        odometry = config.odometry
        self._noise = np.array(
            odometry.velocity_noise if self.velocity_model else odometry.alphas, dtype=np.float64
        )
        beams = sensor.scan_beams
        self._beam_angles = -math.pi + 2.0 * math.pi * (np.arange(beams) + 0.5) / beams
        self._scan_reach = float(sensor.scan_range)
        faults = config.faults
        self.faults_on = faults.any
        self._faults = FaultParams(
            float(faults.scan_dropout),
            float(faults.outlier_rate),
            float(faults.odometry_dropout),
            OUTLIER_MIN_RANGE,
            float(sensor.max_range),
            min(float(sensor.fov), 2.0 * math.pi - 1e-9),
            cartesian,
            float(faults.clutter_rate),
        )
        bias = faults.odometry_bias
        self._bias = np.zeros(self.control_dim) if bias is None else np.array(bias, float)

        # Each step's uniforms: the odometry reading, the scan, then the faults.
        self._scan_offset = odometry_uniforms(self.control_dim)
        self._fault_offset = self._scan_offset + scan_uniforms(self.n_landmarks, d)
        fault_width = FAULT_UNIFORMS + (CLUTTER_UNIFORMS if faults.clutter_rate > 0.0 else 0)
        width = self._fault_offset + (fault_width if self.faults_on else 0)
        # The true ID of each detection goes to info where the observation does not
        # tell it: IDs hidden, or clutter among the detections.
        self.reports_truth = not sensor.report_ids or faults.clutter_rate > 0.0
        self.blocks = RandomBlocks(num_envs, width)
        self.rngs: list[np.random.Generator | None] = [None] * num_envs

        b, c = num_envs, self.control_dim
        self.seen = np.zeros((b, self.n_slots), dtype=bool)
        self.collided = np.zeros(b, dtype=bool)
        self.kidnapped = np.zeros(b, dtype=bool)
        self.control_true = np.zeros((b, c))
        self.control = np.zeros((b, c))
        self.det_z = np.zeros((b, d, 2))
        self.det_ids = np.zeros((b, d), dtype=np.int64)
        self.det_rows = np.zeros((b, d), dtype=np.int64)
        self.det_count = np.zeros(b, dtype=np.int64)
        self.scan = np.zeros((b, beams), dtype=np.float32)
        self.out = RawOutputs(
            np.zeros((b, c), dtype=np.float32),
            np.zeros((b, 2 * d), dtype=np.float32),
            np.full((b, d), -1.0, dtype=np.float32),
            np.zeros((b, d), dtype=np.float32),
            np.zeros((b, 1), dtype=np.float32),
            np.zeros(b, dtype=bool),
            np.zeros(b),
            np.zeros(b),
            np.zeros(b),
        )
        self.terminated = np.zeros(b, dtype=bool)
        self._none = np.zeros(b, dtype=bool)
        self._idle = np.zeros((b, 2))  # the commands of robots that do not move
        # The kernels' grouped arguments as plain tuples (see slam_env.kernels).
        self._sensor_fields = tuple(self._sensor)
        self._fault_fields = tuple(self._faults)
        self._params_fields = tuple(self._params)
        self._out_fields = tuple(self.out)
        self._views: dict[int, dict[str, np.ndarray]] = {}
        self._touched = np.zeros(b, dtype=bool)  # the sub-envs a step moves or resets
        self._stepping = np.zeros(b, dtype=bool)  # the sub-envs a step moves
        # Each chunk's raw_step, its compiled code pinned to its arguments, those
        # arguments but the last two, and the geometry they view (see _raw_step).
        self._step_calls: list[Any] | None = None
        self.threads = RowThreads(num_envs, 1)  # use_threads

    # Views of one sub-env's rows (see _row_views) and the kernel's call: never pickled
    # (a view would come back as a copy, detached from its array), rebuilt.
    _TRANSIENT = ("_views", "_step_calls")

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in self._TRANSIENT}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._views = {}
        self._step_calls = None

    def _row_views(self, index: int) -> dict[str, np.ndarray]:
        """Views of sub-env ``index``'s rows of the observation, made at the first call
        for ``index`` (taking a row costs about as much as copying it)."""
        views = self._views.get(index)
        if views is None:
            views = self._views[index] = {
                key: array[index] for key, array in self._observed().items()
            }
        return views

    # ------------------------------------------------------------------ stepping
    def use_threads(self, num_threads: int) -> None:
        """Step the sub-envs' compiled stages on ``num_threads`` threads, each over a
        contiguous chunk of the rows (:class:`~slam_env.core.chunks.RowThreads`)."""
        self.threads.close()
        self.threads = RowThreads(self.num_envs, num_threads)
        self._step_calls = None

    def close(self) -> None:
        """Join the threads of :meth:`use_threads` (idempotent)."""
        self.threads.close()

    def advance(
        self, commands: np.ndarray, stepping: np.ndarray, resetting: Sequence[int]
    ) -> list[Layout]:
        """Step the sub-envs of ``stepping`` ((B,) bool; robot b driven by
        ``commands[b]``, (B, 2) float64: speed m/s, turn rate rad/s) and start a new episode for
        those listed in ``resetting`` (their generators already in :attr:`rngs`), in the
        same kernel calls. A reset scan has no faults and pays nothing. Returns the new
        episodes' layouts, in the order of ``resetting``."""
        layouts = self.begin(commands, stepping, resetting)
        self.threads.run(self.sense)
        self.finish(resetting)
        return layouts

    def begin(
        self, commands: np.ndarray, stepping: np.ndarray, resetting: Sequence[int]
    ) -> list[Layout]:
        """The Python of :meth:`advance` before its compiled stages: the robots' moves
        and the resets' new worlds. Returns the new episodes' layouts."""
        worlds = self.worlds
        worlds.move(commands, stepping, self.collided)
        if self._step_calls is None:  # each chunk's, made in its thread (_raw_step)
            self._step_calls = [None] * self.threads.count
        np.copyto(self._stepping, stepping)  # into the array the calls are pinned to
        touched = self._touched
        np.copyto(touched, stepping)
        layouts = []
        for b in resetting:
            layouts.append(worlds.reset(b, self.rngs[b]))
            self.blocks.restart(b, self.rngs[b])
            self.seen[b] = False
            self.collided[b] = False
            self.kidnapped[b] = False
            self.control[b] = 0.0
            self.control_true[b] = 0.0
            touched[b] = True
        return layouts

    def sense(self, k: int) -> None:
        """The compiled stages of :meth:`advance` over chunk ``k``'s rows (in its
        thread): the odometry readings, the kidnappings, the scans and observations."""
        if self.faults_on and self.config.faults.kidnap_rate > 0.0:
            # The kidnapping comes between the odometry reading and the scans.
            self._raw_step(k, read=True, sense=False)
            self._kidnap(self.threads.rows[k])
            self._raw_step(k, read=False, sense=True)
        else:
            self._raw_step(k, read=True, sense=True)

    def finish(self, resetting: Sequence[int]) -> None:
        """The Python of :meth:`advance` after its compiled stages: the flags, and the
        new episodes' rewards of 0."""
        out = self.out
        if self.config.terminate_when_all_detected:
            np.logical_and(out.all_seen, self._stepping, out=self.terminated)
        for b in resetting:
            out.new_terms[b] = 0.0
            out.collision_terms[b] = 0.0
            out.rewards[b] = 0.0
            self.terminated[b] = False

    def _kidnap(self, rows: slice | None) -> None:
        """Kidnap the stepping robots of ``rows`` whose uniform says so."""
        rate = self.config.faults.kidnap_rate
        active = rows_of(self._stepping, rows)
        rows_of(self.kidnapped, rows)[active] = False
        uniforms = rows_of(self.blocks.uniforms, rows)
        events = active & (uniforms[:, self._fault_offset + KIDNAP_UNIFORM] < rate)
        first = 0 if rows is None else rows.start
        for b in (first + np.flatnonzero(events)).tolist():
            self.kidnapped[b] = self.worlds.kidnap(b, self.rngs[b])

    def _raw_step(self, k: int, read: bool, sense: bool) -> None:
        """For chunk ``k``'s rows: if ``read``, the uniforms of the touched sub-envs and
        the odometry readings (and their faults) of the stepping ones; if ``sense``,
        the scans and observations: one call of
        :func:`~slam_env.kernels.stream.raw_step.raw_step`, and another after refilling
        used-up blocks."""
        worlds = self.worlds
        calls = self._step_calls
        call = calls[k]
        # A reset may replace the geometry's arrays: then the call is pinned anew.
        if call is None or call[2] is not worlds.geometry_fields:
            args = self._raw_step_args(self.threads.rows[k])
            call = calls[k] = (pin(raw_step, *args, read, sense), args, worlds.geometry_fields)
        compiled, args, _ = call
        rows = self.threads.rows[k]
        while used_up := compiled(*args, read, sense):  # nothing done yet
            self.blocks.refill(used_up, self.rngs, 0 if rows is None else rows.start)

    def _raw_step_args(self, rows: slice | None) -> tuple[Any, ...]:
        """:func:`~slam_env.kernels.stream.raw_step.raw_step`'s arguments but the last
        two, over the sub-envs ``rows`` (None: all), with scratch of their own."""
        worlds = self.worlds

        def own(arrays: Any) -> tuple[np.ndarray, ...]:
            return tuple(rows_of(a, rows) for a in arrays)

        return (
            own(self.blocks.kernel_args),
            (
                rows_of(worlds.before, rows),
                self.velocity_model,
                self._noise,
                rows_of(self.control_true, rows),
                rows_of(self.control, rows),
            ),
            (self._faults.odometry_dropout, self._bias, self._fault_offset)
            if self.faults_on
            else None,
            own((worlds.poses, worlds.landmarks, worlds.landmark_ids, worlds.id_order)),
            own(worlds.geometry_fields),
            self._sensor_fields,
            self._scan_offset,
            rows_of(self._touched, rows),
            own((self.det_z, self.det_ids, self.det_rows, self.det_count)),
            (self._fault_fields, self._fault_offset) if self.faults_on else None,
            (self._beam_angles, self._scan_reach, rows_of(self.scan, rows)),
            rows_of(self.collided, rows),
            rows_of(self.seen, rows),
            self._params_fields,
            own(self._out_fields),
            rows_of(self._stepping, rows),
            sensing_scratch(
                worlds.landmarks.shape[1],
                worlds.geometry.tree.shape[1],
                self._beam_angles.shape[0],
            ),
        )

    @property
    def beam_angles(self) -> np.ndarray:
        """(beams,) rad: the proximity beams' directions in the robot frame."""
        return self._beam_angles

    @property
    def rewards(self) -> np.ndarray:
        """(B,) the rewards of the last step (0 for a reset)."""
        return self.out.rewards

    # ------------------------------------------------------------------ reading
    def observation(self, index: int) -> dict[str, np.ndarray]:
        """Sub-env ``index``'s observation, fresh arrays."""
        return {key: row.copy() for key, row in self._row_views(index).items()}

    def observations(self) -> dict[str, np.ndarray]:
        """Every sub-env's observation, stacked (B, …), fresh arrays."""
        return {key: array.copy() for key, array in self._observed().items()}

    def _observed(self) -> dict[str, np.ndarray]:
        """The (B, …) arrays of the observation, by key (the scan and the bumper where
        the sensor has them)."""
        out = self.out
        arrays = {
            "odometry": out.odometry,
            "detections": out.detections,
            "ids": out.ids,
            "mask": out.mask,
        }
        if self._beam_angles.size:
            arrays["scan"] = self.scan
        if self.config.sensor.bumper:
            arrays["bumper"] = out.bumper
        return arrays

    def frame(self, index: int, trail: Any, belief: Any = None) -> Frame:
        """The plain-data :class:`slam_env.render.renderer.Frame` of sub-env ``index``: the
        robot, its detections, the landmarks seen and the sensor's visible region traced
        in its world (cut by what occludes it), with its past positions ``trail``
        ((T, 2), m) and a belief overlay to draw, if any. The env adds the step."""
        k = int(self.det_count[index])
        pose = self.worlds.poses[index]
        sensor = self.config.sensor
        z = self.det_z[index, :k]
        if sensor.measurement_model == "range_bearing":
            local = np.stack([z[:, 0] * np.cos(z[:, 1]), z[:, 0] * np.sin(z[:, 1])], axis=-1)
        else:
            local = z
        ids = self.worlds.landmark_ids[index]
        at = tuple(pose.tolist())
        return Frame(
            pose=at,
            trail=np.array(trail, dtype=np.float64).reshape(-1, 2),
            detections_world=robot_to_world(pose, local),
            detected_ids=self.det_ids[index, :k].copy(),
            seen_mask=self.seen[index][ids].copy(),
            collision=bool(self.collided[index]),
            belief=belief,
            visible_region=visible_region(
                self.worlds.worlds[index], at, sensor.max_range, sensor.fov
            ),
        )

    def belief_overlay(self, index: int) -> None:
        """Nothing to draw over the world: the raw stream has no belief."""
        return None

    def info(self, index: int) -> dict[str, Any]:
        """Sub-env ``index``'s info (the ground truth), fresh objects: its row of
        :meth:`infos`."""
        return info_row(*self.infos(), index)

    def detection_ids(self, index: int | slice) -> np.ndarray:
        """(D,) int64 (or (B, D) for a slice): the true landmark ID of each detection
        row of the observation, -1 for clutter and padding."""
        rows = np.arange(self.max_detections)
        return np.where(rows < self.det_count[index, None], self.det_ids[index], -1)

    def infos(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Every sub-env's info, stacked (B, …), fresh arrays, in the order of
        :data:`~slam_env.info_keys.RAW_INFO`, and the masks of the keys that not every
        sub-env reports (none here: every key, every sub-env)."""
        worlds = self.worlds
        info = {
            "pose": worlds.poses.copy(),
            "landmark_positions": worlds.landmarks.copy(),
            "landmark_ids": worlds.landmark_ids.copy(),
            "collision": self.collided.copy(),
            "seen": self.seen.copy(),
            "odometry_true": self.control_true.copy(),
            "reward_terms": {
                "new_landmarks": self.out.new_terms.copy(),
                "collision": self.out.collision_terms.copy(),
            },
        }
        if self.faults_on:
            info["kidnapped"] = self.kidnapped.copy()
        if self.reports_truth:
            info["detection_ids"] = self.detection_ids(slice(None))
        return info, {}
