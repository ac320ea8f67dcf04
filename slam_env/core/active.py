"""The active-SLAM stream of B sub-envs of one config: the raw core, then each sub-env's
EKF-SLAM filter, swept-area memory, belief observation and reward, each a kernel call
over all of them.

:class:`ActiveCore` is what ``slam_env/ActiveSLAM-v0`` runs as a batch of one and its
native vector env for B sub-envs. It computes exactly what the composable wrappers
(:class:`slam_env.belief.ekf_wrapper.EKFSLAMWrapper`,
:class:`slam_env.belief.coverage_wrapper.CoverageWrapper`,
:class:`slam_env.belief.reward_wrapper.ActiveSLAMReward`) compute over a raw env, with
the same kernels.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from gymnasium import spaces

from slam_env.belief.coverage import CoverageGrid
from slam_env.belief.encodings import (
    PASSTHROUGH_KEYS,
    BeliefGeometry,
    EgocentricEncoding,
    FullEncoding,
)
from slam_env.belief.entropy import BeliefEntropy
from slam_env.belief.local_encoding import LocalEncoding
from slam_env.belief.overlay import BeliefOverlay
from slam_env.belief.reward import REWARD_TERMS
from slam_env.config import EnvConfig
from slam_env.core.active_options import ActiveSLAMOptions
from slam_env.core.batch import BatchCore
from slam_env.core.chunks import rows_of
from slam_env.core.random_blocks import RandomBlocks
from slam_env.core.raw import RawCore
from slam_env.ekf import EKFSLAM
from slam_env.ekf.batch import FilterBatch
from slam_env.info_keys import info_row
from slam_env.kernels.belief.active_step import belief_outputs, filter_step, step_reward
from slam_env.kernels.belief.diagnostics import (
    DIAGNOSTICS,
)
from slam_env.kernels.belief.divergence import DIVERGENCE_REJECTIONS, diverged
from slam_env.kernels.ekf.association_score import SCORE_NAMES
from slam_env.smoothing.batch import SmootherBatch
from slam_env.smoothing.isam2 import ISAM2SLAM
from slam_env.world.layouts import Layout

# Rows of the diagnostics kernel's output, by name.
_DIAGNOSTIC_ROW = {name: i for i, name in enumerate(DIAGNOSTICS)}


class _Chunk(NamedTuple):
    """What :class:`ActiveCore` passes its step's kernels over one thread's chunk of
    the sub-envs' rows (all of them for None) that never changes: views of the core's
    arrays, the diagnostics and scratch of its own."""

    rows: slice | None
    filter_inputs: tuple  # filter_step's, before the masks
    masks: tuple  # (touched, stepping)
    filter_state: tuple  # … after the masks, before the workspaces
    filter_books: tuple  # … after the association flag
    outputs: tuple  # belief_outputs's, before the masks
    diagnostics: np.ndarray  # (diagnostics, chunk): the core's, or its own to copy back
    finish: tuple  # (P, n, entropy, ok) for the entropies the kernel leaves
    reward: tuple  # step_reward's arguments before the masks, for those entropies


class ActiveCore(BatchCore):
    """B sub-envs of ``slam_env/ActiveSLAM-v0`` with one config, stepped together.

    Each step: :class:`RawCore`'s step, then the filters' prediction with the odometry
    reading and their update with the detections (as the observation reports them),
    the diagnostics against the truth, the belief entropy, the swept-area memory from
    the estimated pose, the belief observation and the reward terms. Results stay in
    the arrays until the next call; :meth:`observation`/:meth:`info` copy one sub-env's
    out, :meth:`observations`/:meth:`infos` all. ``max_updates``: the iSAM2 updates a
    smoothing belief may hold in an episode (its share of the memory budget,
    :func:`slam_env.budget.smoother_updates`).
    """

    has_belief = True

    def __init__(
        self,
        config: EnvConfig,
        num_envs: int,
        options: ActiveSLAMOptions,
        *,
        max_updates: int,
    ) -> None:
        self.config = config
        self.num_envs = b = num_envs
        self.options = options
        raw = self.raw = RawCore(config, num_envs)
        m, d = raw.n_slots, raw.max_detections
        width, height = raw.arena_size
        sensor, odometry = config.sensor, config.odometry
        template = EKFSLAM(
            motion_model=odometry.motion_model,
            measurement_model=sensor.measurement_model,
            alphas=options.filter_alphas or odometry.alphas,
            control_noise=options.filter_control_noise or odometry.velocity_noise,
            measurement_cov=(
                sensor.measurement_cov
                if options.filter_measurement_cov is None
                else options.filter_measurement_cov
            ),
            max_landmarks=m,
            gate=options.gate,
            correction=options.correction,
            data_association=options.data_association,
            linearization=options.linearization,
            new_landmark_sightings=options.new_landmark_sightings,
            wide_pairing_scans=options.wide_pairing_scans,
        )
        self.filters = FilterBatch(b, template, d)
        # belief="isam2": the filters' state holds the smoothers' beliefs, which their
        # step (prediction, gate, association) reads and the smoothers then replace.
        self.smoothers: SmootherBatch | None = None
        if options.belief == "isam2":
            self.smoothers = SmootherBatch(
                self.filters,
                max_updates,
                relinearize_threshold=options.smoothing_relinearize_threshold,
                relinearize_skip=options.smoothing_relinearize_skip,
                keyframes=options.smoothing_keyframes,
                window=options.smoothing_window,
            )
        # Where the filters associate: the true landmark of each filter landmark, the
        # map size before the update, and the association's scores (step, episode).
        self.associates = template.associates
        self.slot_truth = np.full((b, m), -1, dtype=np.int64)
        self._n_before = np.zeros(b, dtype=np.int64)
        self.score_step = np.zeros((b, len(SCORE_NAMES)), dtype=np.int64)
        self.score_episode = np.zeros((b, len(SCORE_NAMES)), dtype=np.int64)
        self._geometry = BeliefGeometry(m, width, height, sensor.max_range)
        self._entropy_of = BeliefEntropy(m, width, height)
        self._passthrough = tuple(k for k in PASSTHROUGH_KEYS if k in raw.observation_space.spaces)
        self.coverage: CoverageGrid | None = None
        if options.coverage:
            self.coverage = CoverageGrid.for_sensor(width, height, sensor, worlds=b)
        self._local: dict[str, np.ndarray] | None = None
        if options.observation == "full":
            self._encoding: FullEncoding | EgocentricEncoding | LocalEncoding = FullEncoding(
                self._geometry
            )
            self._full = self._encoding.empty(b)
        elif options.observation == "local":
            assert self.coverage is not None  # ActiveSLAMOptions requires it
            self._encoding = LocalEncoding(
                self._geometry,
                raw.n_landmarks,
                self.coverage,
                raw.beam_angles,
                sensor.scan_range,
            )
            self._local = self._encoding.empty(b)
        else:
            self._encoding = EgocentricEncoding(self._geometry)
        self.observation_space = self._observation_space(raw.observation_space)
        self._weights = np.array([getattr(options.weights, name) for name in REWARD_TERMS])

        # The truth by landmark ID (NaN where a world has no such ID), per world.
        self.truth = np.full((b, m, 2), np.nan)
        # Each world's step: what went wrong with its filter, the diagnostics, the
        # entropy, the observation and the reward.
        self.failed = np.zeros(b, dtype=bool)
        self.in_a_row = np.zeros(b, dtype=np.int64)
        self.updated = np.zeros(b, dtype=bool)
        self._counted = np.zeros(b, dtype=bool)  # the updates that succeeded
        self._touched = np.zeros(b, dtype=bool)  # the sub-envs a step moves or resets
        # Each chunk's kernel arguments and workspaces (_make_chunks), made at the first step.
        self._chunks: list[_Chunk] | None = None
        self._workspaces: list[tuple] = []
        self.diagnostics = np.zeros((len(DIAGNOSTICS), b))
        self.entropy = np.zeros(b)
        self._entropy_ok = np.zeros(b, dtype=bool)
        self.clipped = np.zeros(b, dtype=bool)
        self.diverged = np.zeros(b, dtype=bool)
        self.swept_fraction = np.zeros(b)
        coverage_width = 0 if self.coverage is None else 1 + self.coverage.n_features
        raw_width = sum(raw.observation_space[k].shape[0] for k in self._passthrough)
        # The egocentric observation's tail: the raw proximity readings, then coverage.
        self._tail = np.zeros((b, raw_width + coverage_width), dtype=np.float32)
        self._no_readings = np.zeros((b, 0), dtype=np.float32)
        self.egocentric = (
            np.zeros((b, self.observation_space.shape[0]), np.float32)
            if (options.observation == "egocentric")
            else None
        )
        self.last = np.zeros((b, 2))  # the previous step's entropy and swept fraction
        self.terms = np.zeros((b, len(REWARD_TERMS)))
        self.rewards = np.zeros(b)
        self._none = np.zeros(b, dtype=bool)

    def _observation_space(self, raw_space: spaces.Dict) -> spaces.Space:
        """The belief encoding's space with the raw proximity sensors' and the
        coverage features' (see :class:`slam_env.envs.active_slam.ActiveSLAMEnv`)."""
        extra = {k: raw_space[k] for k in self._passthrough}
        if self.coverage is not None:
            n = 1 + self.coverage.n_features
            extra["coverage"] = spaces.Box(0.0, 1.0, (n,), np.float32)
        belief = self._encoding.space
        if isinstance(belief, spaces.Dict):
            return spaces.Dict({**belief.spaces, **extra})
        return spaces.Box(
            np.concatenate([belief.low, *(e.low for e in extra.values())]),
            np.concatenate([belief.high, *(e.high for e in extra.values())]),
            dtype=np.float32,
        )

    # ------------------------------------------------------------------ stepping
    @property
    def rngs(self) -> list[np.random.Generator | None]:
        return self.raw.rngs

    @property
    def blocks(self) -> RandomBlocks:
        return self.raw.blocks

    # The kernels' fixed arguments hold views of the coverage grid and of the core's
    # arrays (rebuilt when unpickled): never pickled, rebuilt at the first step.
    _TRANSIENT = ("_chunks", "_workspaces")

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in self._TRANSIENT}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._chunks, self._workspaces = None, []

    def use_threads(self, num_threads: int) -> None:
        """Step the sub-envs' compiled stages on ``num_threads`` threads, each over a
        contiguous chunk of the rows (:class:`~slam_env.core.chunks.RowThreads`)."""
        self.raw.use_threads(num_threads)
        self._chunks, self._workspaces = None, []

    def close(self) -> None:
        """Join the threads of :meth:`use_threads` (idempotent)."""
        self.raw.close()

    def _make_chunks(self) -> None:
        """Every chunk's :class:`_Chunk` and workspaces, if not made yet: before the
        threads run, which only read them. Their arrays never change (the workspaces,
        which grow, are replaced in place), and building the tuples at every step cost
        as much as the calls."""
        if self._chunks is None:
            rows = self.raw.threads.rows
            self._chunks = [self._chunk_args(r) for r in rows]
            self._workspaces = [
                self.filters.workspaces if r is None else self.filters.workspaces_of(r)
                for r in rows
            ]

    def _chunk_args(self, rows: slice | None) -> _Chunk:
        """A :class:`_Chunk` over the sub-envs ``rows`` (None: all of them)."""
        raw, filters = self.raw, self.filters
        out = raw.out

        def own(arrays: Any) -> tuple[np.ndarray, ...]:
            return tuple(rows_of(a, rows) for a in arrays)

        readings = own((out.odometry, out.detections, out.ids, raw.det_count, raw.det_ids))
        # The map error pairs each filter landmark with its true one: the IDs are
        # the truth's, unless the filter made its own.
        truth_of_slots = self.slot_truth if self.associates else filters.slot_to_id
        params, modes, joint_gates = filters.config
        if rows is None:
            diagnostics, entropy_of = self.diagnostics, self._entropy_of.kernel_args
            coverage = None if self.coverage is None else self.coverage.kernel_args
        else:  # (diagnostics, B): a chunk's columns are not contiguous; copied back
            diagnostics = self.diagnostics[:, rows].copy()
            entropy_of = self._entropy_of.kernel_args_of_a_thread()
            coverage = None if self.coverage is None else self.coverage.kernel_args_of(rows)
        belief = own((filters.x, filters.P, filters.n, filters.slot_to_id))
        entropy, entropy_ok = rows_of(self.entropy, rows), rows_of(self._entropy_ok, rows)
        swept_fraction = rows_of(self.swept_fraction, rows)
        reward = (
            self._weights,
            rows_of(raw.collided, rows),
            rows_of(self.last, rows),
            rows_of(self.terms, rows),
            rows_of(self.rewards, rows),
        )
        return _Chunk(
            rows=rows,
            filter_inputs=(readings, not self.associates),
            masks=(rows_of(self._touched, rows), rows_of(raw._stepping, rows)),
            filter_state=(
                own(filters.storage),
                (rows_of(params, rows), rows_of(modes, rows), joint_gates),
                rows_of(filters.u, rows),
                own(filters.correction_io),
            ),
            filter_books=(
                own((self.updated, self.failed, self._counted, self.in_a_row)),
                own((self.slot_truth, self._n_before, self.score_step, self.score_episode)),
            ),
            outputs=(
                belief,
                own((truth_of_slots, raw.worlds.poses, self.truth)),
                diagnostics,
                entropy_of,
                entropy,
                entropy_ok,
                own(self._passthrough_readings),
                coverage,
                rows_of(self._tail, rows),
                swept_fraction,
                reward,
            ),
            diagnostics=diagnostics,
            finish=(belief[1], belief[2], entropy, entropy_ok),
            reward=(reward, entropy, diagnostics, swept_fraction),
        )

    @property
    def _idle(self) -> np.ndarray:
        return self.raw._idle

    def advance(
        self, commands: np.ndarray, stepping: np.ndarray, resetting: Sequence[int]
    ) -> list[Layout]:
        """Step the sub-envs of ``stepping`` by their ``commands`` and start a new
        episode for those listed in ``resetting``, in the same kernel calls (see
        :meth:`RawCore.advance`). A new episode's filter starts at the true start pose
        and folds in the first scan; its reward is 0, and the next step's gains are
        measured from it."""
        raw, filters = self.raw, self.filters
        self.check_room(stepping)
        layouts = raw.begin(commands, stepping, resetting)
        touched = self._touched
        np.copyto(touched, stepping)
        worlds = raw.worlds
        for b in resetting:
            self.truth[b] = np.nan
            self.truth[b, worlds.landmark_ids[b]] = worlds.landmarks[b]
            filters.reset(b, worlds.poses[b])
            if self.smoothers is not None:
                self.smoothers.reset(b, worlds.poses[b], filters)
            self.slot_truth[b] = -1
            self.score_episode[b] = 0
            self.failed[b] = False
            self.in_a_row[b] = 0
            if self.coverage is not None:
                self.coverage.reset(b)
            if self._local is not None:
                self._encoding.reset(b)
            touched[b] = True
        threads = raw.threads
        self._make_chunks()
        if self.smoothers is None:
            threads.run(self._step_chunk)
        else:  # the smoothers follow the filters, in Python, before the outputs
            threads.run(self._sense_and_filter)
            self.smoothers.follow(filters, touched, raw._stepping, self.failed)
            threads.run(self._outputs)
        if threads.count > 1:
            for chunk in self._chunks:
                self.diagnostics[:, chunk.rows] = chunk.diagnostics
        raw.finish(resetting)
        self._encode()
        return layouts

    def _step_chunk(self, k: int) -> None:
        """Chunk ``k``'s compiled stages (in its thread): the raw step, the filters and
        the belief's outputs."""
        self._sense_and_filter(k)
        self._outputs(k)

    def _sense_and_filter(self, k: int) -> None:
        """Chunk ``k``'s raw step and filters."""
        self.raw.sense(k)
        chunk = self._chunks[k]
        filtering = (*chunk.filter_inputs, *chunk.masks, *chunk.filter_state)
        rest = (self.associates, *chunk.filter_books)
        if not filter_step(*filtering, self._workspaces[k], *rest):
            if chunk.rows is None:
                self.filters.grow_for(self.updated)
                self._workspaces[k] = self.filters.workspaces
            else:
                self._workspaces[k] = self.filters.workspaces_of(chunk.rows)
            filter_step(*filtering, self._workspaces[k], *rest)

    def check_room(self, stepping: np.ndarray) -> None:
        """``RuntimeError``, nothing changed, where a smoothing belief that steps would
        outgrow its share of the memory budget (it records every update of its
        episode: :meth:`SmootherBatch.check_room`)."""
        if self.smoothers is not None:
            self.smoothers.check_room(stepping)

    @property
    def terminated(self) -> np.ndarray:
        return self.raw.terminated

    @property
    def _passthrough_readings(self) -> tuple[np.ndarray, np.ndarray]:
        """The raw proximity readings the observation passes on, in
        :data:`PASSTHROUGH_KEYS` order (scan, bumper), (B, 0) for a sensor the env
        lacks."""
        raw, keys, none = self.raw, self._passthrough, self._no_readings
        return (
            raw.scan if "scan" in keys else none,
            raw.out.bumper if "bumper" in keys else none,
        )

    def _outputs(self, k: int) -> None:
        """Chunk ``k``'s diagnostics, entropy, coverage and reward."""
        chunk = self._chunks[k]
        if belief_outputs(*chunk.outputs, *chunk.masks):  # the rare entropy left by round-off
            touched, stepping = chunk.masks
            self._entropy_of.finish(*chunk.finish, touched)
            step_reward(*chunk.reward, touched, stepping)

    def _encode(self) -> None:
        """The observation and ``diverged`` of the touched worlds."""
        filters, raw, touched = self.filters, self.raw, self._touched
        belief = (filters.x, filters.P, filters.n, filters.slot_to_id)
        if self.egocentric is not None:
            self._encoding.encode_batch(belief, self._tail, self.egocentric, self.clipped, touched)
        elif self._local is not None:
            self._encoding.encode_batch(belief, raw.scan, self._local, self.clipped, touched)
        else:
            self._encoding.encode_batch(belief, self._full, touched)
            np.copyto(self.clipped, self._full.clipped)
        diverged(self.clipped, self.failed, self.in_a_row, DIVERGENCE_REJECTIONS, self.diverged)

    # ------------------------------------------------------------------ reading
    def observation(self, index: int) -> Any:
        """Sub-env ``index``'s observation, fresh arrays."""
        if self.egocentric is not None:
            return self.egocentric[index].copy()
        return self._full_observation(slice(index, index + 1), 0)

    def observations(self) -> Any:
        """Every sub-env's observation, stacked (B, …), fresh arrays."""
        if self.egocentric is not None:
            return self.egocentric.copy()
        return self._full_observation(slice(None), None)

    def _full_observation(self, rows: slice, pick: int | None) -> dict[str, np.ndarray]:
        """The Dict observation (the full or the local belief, then the raw proximity
        readings and the coverage) of the sub-envs ``rows``; ``pick`` one of them."""
        raw = self.raw
        if self._local is not None:
            obs = {key: value[rows] for key, value in self._local.items()}
        else:
            full = self._full
            obs = {"mean": full.mean[rows], "cov": full.cov[rows], "known": full.known[rows]}
        for key in self._passthrough:
            obs[key] = (raw.scan if key == "scan" else raw.out.bumper)[rows]
        if self.coverage is not None:
            obs["coverage"] = self._tail[rows, -(1 + self.coverage.n_features) :]
        return {k: (v[pick] if pick is not None else v).copy() for k, v in obs.items()}

    def info(self, index: int) -> dict[str, Any]:
        """Sub-env ``index``'s info, fresh objects: its row of :meth:`infos`."""
        return info_row(*self.infos(), index)

    def infos(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Every sub-env's info, stacked (B, …), fresh arrays, in the order of
        :data:`~slam_env.info_keys.ACTIVE_INFO`, and the masks of the keys that not
        every sub-env reports (the undefined metrics)."""
        info, _ = self.raw.infos()
        info["raw_reward_terms"] = info.pop("reward_terms")
        diag = {name: self.diagnostics[row].copy() for name, row in _DIAGNOSTIC_ROW.items()}
        masks = {}
        for name in ("map_rmse", "pose_nees"):
            defined = ~np.isnan(diag[name])
            masks[name] = defined
            diag[name][~defined] = 0.0  # Gymnasium's value where a sub-env reports nothing
        info["pose_error"] = diag["pose_error"]
        info["heading_error"] = diag["heading_error"]
        info["map_rmse"] = diag["map_rmse"]
        info["pose_nees"] = diag["pose_nees"]
        info["landmarks_known"] = self.filters.n.copy()
        info["rejected"] = self.filters.n_rejected.copy()
        info["entropy"] = self.entropy.copy()
        info["pose_std"] = diag["pose_std"]
        info["belief_clipped"] = self.clipped.copy()
        info["consecutive_rejections"] = self.in_a_row.copy()
        info["diverged"] = self.diverged.copy()
        if self.coverage is not None:
            info["swept_fraction"] = self.swept_fraction.copy()
        info["reward_terms"] = {
            name: self.terms[:, i].copy() for i, name in enumerate(REWARD_TERMS)
        }
        if self.associates:
            for key, scores in (
                ("association", self.score_step),
                ("association_episode", self.score_episode),
            ):
                info[key] = {name: scores[:, i].copy() for i, name in enumerate(SCORE_NAMES)}
        return info, masks

    def filter(self, index: int) -> EKFSLAM:
        """Sub-env ``index``'s filter, over the batch's storage (with
        ``belief="isam2"``, the smoothing belief as a Gaussian: see :meth:`smoother`)."""
        return self.filters.filter(index)

    def smoother(self, index: int) -> ISAM2SLAM:
        """Sub-env ``index``'s smoothing belief (``belief="isam2"``); ``ValueError``
        with the EKF belief."""
        if self.smoothers is None:
            raise ValueError("this env's belief is 'ekf': it has no smoother (belief='isam2')")
        return self.smoothers[index]

    def belief_overlay(self, index: int, true_landmarks: Any = None) -> BeliefOverlay:
        """What the pictures draw of sub-env ``index``'s belief (and ``true_landmarks``
        (N, 2) beside it, if given)."""
        f = self.filter(index)
        return BeliefOverlay.from_state(f.mean, f.cov, f.state_to_id, true_landmarks)

    def frame(self, index: int, trail: Any, belief: Any = None) -> Any:
        return self.raw.frame(index, trail, belief)

    # What the single env reads of its world, as of the raw core.
    @property
    def worlds(self):
        return self.raw.worlds

    @property
    def n_landmarks(self) -> int:
        return self.raw.n_landmarks

    @property
    def n_slots(self) -> int:
        return self.raw.n_slots

    @property
    def arena_size(self) -> tuple[float, float]:
        return self.raw.arena_size

    @property
    def max_detections(self) -> int:
        return self.raw.max_detections
