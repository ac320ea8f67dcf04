"""Native Gymnasium vector envs: B sub-envs stepped together by one batched core.

``gym.make_vec("slam_env/Landmarks-v0", num_envs=B, vectorization_mode="vector_entry_point")``
(and the same for ``slam_env/ActiveSLAM-v0``) returns a :class:`SlamVectorEnv` whose
sub-env i, reset with seed s, replays the single env reset with seed s + i exactly:
the single envs are the same core with B = 1, and every sub-env draws from its own
generator, seeded as the single env would be. With ``num_threads=T`` the core's compiled
stages run over T chunks of the sub-envs concurrently (see :class:`SlamVectorEnv`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from gymnasium import error as gym_error
from gymnasium import logger, spaces
from gymnasium.error import ResetNeeded
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from slam_env.core.chunks import thread_count
from slam_env.ekf import EKFSLAM
from slam_env.envs.actions import DISCRETE_PRIMITIVES, parse_actions
from slam_env.envs.options import active_core, raw_core
from slam_env.envs.pictures import Pictures
from slam_env.envs.registration import DEFAULT_MAX_EPISODE_STEPS
from slam_env.smoothing import ISAM2SLAM


def with_masks(
    info: dict[str, Any], reported: np.ndarray, masks: dict[str, np.ndarray] | None = None
) -> dict[str, Any]:
    """A vector info in Gymnasium's convention: next to every key its ``_key`` mask of
    the sub-envs that reported it, ``reported`` ((B,) bool), and with it ``masks[key]``
    for a key that not all of them report (a key none reports is left out); nested
    dicts likewise."""
    masks = masks or {}
    anyone = bool(reported.any())  # once: most keys are reported by every sub-env
    out: dict[str, Any] = {}
    for key, value in info.items():
        own = masks.get(key)
        mask = reported.copy() if own is None else reported & own
        if not (anyone if own is None else mask.any()):
            continue  # as Gymnasium: a key no sub-env reported is not there
        out[key] = with_masks(value, reported) if isinstance(value, dict) else value
        out[f"_{key}"] = mask
    return out


def _select(info: dict[str, Any], rows: np.ndarray) -> dict[str, Any]:
    """The vector info of the sub-envs ``rows`` (B,) bool: the same keys and shapes,
    zeros (or None) elsewhere, as Gymnasium builds it sub-env by sub-env."""
    out: dict[str, Any] = {}
    for key, value in info.items():
        if isinstance(value, dict):
            out[key] = _select(value, rows)
        else:
            kept = np.zeros_like(value)
            kept[rows] = value[rows]
            out[key] = kept
    return out


def _mask_of(options: Any, num_envs: int, name: str) -> np.ndarray | None:
    """The ``reset_mask`` of reset ``options`` ((B,) bool, a copy), None for a reset of
    every sub-env; ``TypeError``/``ValueError`` for anything else, as SyncVectorEnv
    refuses a bad mask (and the single envs any other option)."""
    if options is None:
        return None
    if not isinstance(options, Mapping):
        raise TypeError(
            f"{name}.reset options must be a dict or None, got {type(options).__name__}"
        )
    others = sorted(map(str, set(options) - {"reset_mask"}))
    if others:
        raise ValueError(
            f"{name}.reset takes only reset_mask in its options (the sub-envs take no "
            f"reset options), got {others}"
        )
    if "reset_mask" not in options:
        return None
    mask = options["reset_mask"]
    if not isinstance(mask, np.ndarray):
        raise TypeError(
            f"options['reset_mask'] must be a numpy array of {num_envs} bools, "
            f"got {type(mask).__name__}"
        )
    if mask.shape != (num_envs,):
        raise ValueError(f"options['reset_mask'] must have shape ({num_envs},), got {mask.shape}")
    if mask.dtype != np.bool_:
        raise TypeError(f"options['reset_mask'] must have dtype bool, got {mask.dtype}")
    if not mask.any():
        raise ValueError("options['reset_mask'] must hold at least one True (a sub-env to reset)")
    return mask.copy()


class SlamVectorEnv(VectorEnv):
    """B sub-envs of one slam_env ID with one config, stepped by batched cores.

    It offers Gymnasium's vector API as :class:`gymnasium.vector.SyncVectorEnv` does
    over the same ID, with the same results bit for bit (observations, rewards, flags,
    infos with their ``_key`` masks): sub-env i is the single env, reset with seed
    s + i.

    Args:
        num_envs: B.
        core_factory: ``(num_envs, options, owner) -> core``, the batched core of the
            ID's sub-envs (:func:`slam_env.envs.options.raw_core` for ``Landmarks-v0``),
            the options checked for all of them together, an unknown one refused as
            Python refuses it for the function ``owner``.
        max_episode_steps: truncation, as ``gym.make``'s ``TimeLimit`` does for the single
            env (``None``: never).
        autoreset_mode: an :class:`~gymnasium.vector.AutoresetMode` or its value, also
            :attr:`autoreset_mode` and ``metadata["autoreset_mode"]``. ``NEXT_STEP``
            (default): a sub-env that ended is reset by the next ``step``, which returns
            its first observation with reward 0 and ignores its action. ``SAME_STEP``:
            reset within the same ``step``; the last observation and info are in
            ``info["final_obs"]`` and ``info["final_info"]``. ``DISABLED``: never reset
            by ``step``; reset the ended sub-envs with
            ``reset(options={"reset_mask": terminated | truncated})`` before the next
            ``step`` (which refuses with ``ResetNeeded`` otherwise).
        render_mode: ``None`` or ``"rgb_array"`` (``render()`` returns a frame per
            sub-env, the single env's frame of the same state).
        num_threads: T, how many threads step the sub-envs: an int from 1 to B, or
            ``None`` (default) for the cores this process may run on
            (``len(os.sched_getaffinity(0))``) but at most B // 64
            (:func:`slam_env.core.chunks.default_threads`: below 64 sub-envs a thread,
            threads cost about what they save), so 1 below 128. One core holds every
            sub-env and runs a step's Python once, in the calling thread; with T > 1
            its compiled stages (the scans, the filters, the belief's outputs) run
            over T contiguous chunks of the sub-envs (sizes as even as can be)
            concurrently (:class:`slam_env.core.chunks.RowThreads`): chunk 0 in the
            calling thread, the others on T - 1 threads kept between steps, joined by
            ``close()``. The streams are the same bit for bit whatever T is. A call in
            which a chunk raised raises that exception once every chunk is done, and
            the env then refuses to step (``ResetNeeded``) until a reset of every
            sub-env.
        options: every option of the single env (flat or nested), the same for all
            sub-envs.
    """

    def __init__(
        self,
        num_envs: int,
        core_factory: Callable[..., Any],
        *,
        max_episode_steps: int | None = DEFAULT_MAX_EPISODE_STEPS,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        render_mode: str | None = None,
        num_threads: int | None = None,
        **options: Any,
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)):
            raise TypeError(f"num_envs must be an int, got {type(num_envs).__name__}")
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        if max_episode_steps is not None and (
            isinstance(max_episode_steps, bool)
            or not isinstance(max_episode_steps, (int, np.integer))
            or max_episode_steps < 1
        ):
            raise ValueError(
                f"max_episode_steps must be an int >= 1 or None, got {max_episode_steps!r}"
            )
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ValueError(
                f"autoreset_mode must be one of {[m.value for m in AutoresetMode]} (or an "
                f"AutoresetMode), got {autoreset_mode!r}"
            ) from None
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.num_envs = int(num_envs)
        self.num_threads = thread_count(num_threads, self.num_envs)
        self.core = core_factory(self.num_envs, options, f"{type(self).__name__}.__init__")
        self.core.use_threads(self.num_threads)
        self.config = self.core.config
        self.autoreset_mode = mode
        self.metadata = {
            "render_modes": ["rgb_array"],
            "render_fps": 10,
            "autoreset_mode": mode,
        }
        self.render_mode = render_mode
        self.max_episode_steps = None if max_episode_steps is None else int(max_episode_steps)
        self.single_observation_space = self.core.observation_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        if self.config.action_type == "continuous":
            self.single_action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        else:
            self.single_action_space = spaces.Discrete(len(DISCRETE_PRIMITIVES))
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        robot = self.config.robot
        self._max_command = np.array([robot.max_speed, robot.max_turn_rate])
        b = self.num_envs
        self._elapsed = np.zeros(b, dtype=np.int64)
        # The sub-envs that ended in the last step and were not reset since: NEXT_STEP
        # resets them in the next step, DISABLED refuses to step them.
        self._autoreset = np.zeros(b, dtype=bool)
        self._sub_seeds: list[int | None] = [None] * b  # each sub-env's, np_random_seed
        self._started = False
        self._failed = False  # a step or reset raised part-way: a full reset is needed
        self._all = np.ones(b, dtype=bool)
        self._idle = np.zeros((b, 2))  # the commands of sub-envs that only reset
        # Each sub-env's paths, step count and renderer: the single env's helper.
        self._pictures = Pictures(self.core, render_mode, self.metadata["render_fps"])

    # ------------------------------------------------------------------ API
    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[Any, dict[str, Any]]:
        """Reset every sub-env, or with ``options={"reset_mask": mask}`` ((B,) bool
        numpy array, at least one True) only those of ``mask``, as SyncVectorEnv does:
        the others keep their observations (returned as they were) and episodes, and
        the info reports only the reset ones (with ``_key`` masks; zeros elsewhere).
        ``reset_mask`` is the only option; a partial mask needs a full reset first.

        ``seed``: an int s seeds sub-env i with s + i; a list gives each sub-env its
        own (``None`` entries continue that sub-env's generator, or draw fresh entropy
        the first time; with a mask, the entries of sub-envs not reset are not used).
        Every argument is checked before anything changes: a refused call leaves the
        env as it was."""
        name = type(self).__name__
        mask = _mask_of(options, self.num_envs, name)
        generators = self._generators(self._seeds(seed))
        if mask is None:
            mask = self._all
        elif not self._started and not mask.all():
            raise ResetNeeded(
                f"{name}: reset every sub-env (a reset without reset_mask) before a reset "
                f"of some, got reset_mask={mask.tolist()}"
            )
        # Checked: from here on nothing raises.
        rows = np.flatnonzero(mask).tolist()
        rngs = self.core.rngs
        for b in rows:
            made = generators[b]
            if made is None and rngs[b] is None:
                made = seeding.np_random()  # fresh entropy, the first time only
            if made is not None:
                rngs[b], self._sub_seeds[b] = made
        self._advance(self._idle, ~self._all, rows)
        self._finish_resets(rows)
        self._autoreset[rows] = False
        self._started = True
        self._failed = False
        info, masks = self.core.infos()
        if len(rows) < self.num_envs:
            info = _select(info, mask)
        return self.core.observations(), with_masks(info, mask.copy(), masks)

    def _seeds(self, seed: int | Sequence[int | None] | None) -> list[Any]:
        b = self.num_envs
        if seed is None:
            return [None] * b
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            return [int(seed) + i for i in range(b)]
        if isinstance(seed, Sequence) and not isinstance(seed, str):
            if len(seed) != b:
                raise ValueError(f"seed must list {b} seeds (one per sub-env), got {len(seed)}")
            return [int(s) if isinstance(s, np.integer) else s for s in seed]
        raise TypeError(f"seed must be an int, a list of {b} ints or None, got {seed!r}")

    @staticmethod
    def _generators(seeds: list[Any]) -> list[tuple[np.random.Generator, int] | None]:
        """Each sub-env's new generator and its seed (None where its seed is None),
        made before any is used, so that a bad seed (Gymnasium's ``error.Error``, as
        the single env's) changes nothing."""
        made = []
        for i, s in enumerate(seeds):
            try:
                made.append(None if s is None else seeding.np_random(s))
            except gym_error.Error as err:
                raise type(err)(f"seed[{i}] (sub-env {i}): {err}") from None
        return made

    def _advance(self, commands: np.ndarray, stepping: np.ndarray, resetting: list[int]) -> None:
        """The core's :meth:`~slam_env.core.raw.RawCore.advance`; if it raises (in any
        chunk's thread), its sub-envs are left part-way through the call, so the env
        refuses to step (``ResetNeeded``) until a reset of every sub-env."""
        try:
            self.core.advance(commands, stepping, resetting)
        except BaseException:
            self._started, self._failed = False, True
            raise

    @property
    def np_random_seed(self) -> tuple[int, ...]:
        """Each sub-env's seed, as :class:`~gymnasium.vector.SyncVectorEnv` reports
        them: the one its last seeded reset gave it (s + i after ``reset(seed=s)``), or
        the entropy its generator was drawn from. A sub-env not seeded yet gets its
        generator now, as ``Env.np_random_seed`` does, which ``reset(seed=None)`` then
        continues."""
        rngs = self.core.rngs
        for b, seed in enumerate(self._sub_seeds):
            if seed is None:
                rngs[b], self._sub_seeds[b] = seeding.np_random()
        return tuple(self._sub_seeds)

    def _finish_resets(self, rows: list[int]) -> None:
        """After the sub-envs ``rows`` reset: their step counts and pictures."""
        self._elapsed[rows] = 0
        self._pictures.restart(rows)

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._started:
            if self._failed:
                raise ResetNeeded(
                    "the last step() or reset() raised part-way through: reset() every "
                    "sub-env before step()"
                )
            raise ResetNeeded("call reset() before step()")
        mode = self.autoreset_mode
        if mode == AutoresetMode.DISABLED and self._autoreset.any():
            ended = np.flatnonzero(self._autoreset).tolist()
            raise ResetNeeded(
                f"sub-envs {ended} ended and autoreset_mode is DISABLED: reset them with "
                "reset(options={'reset_mask': terminated | truncated}) before step()"
            )
        core = self.core
        resetting = self._autoreset  # none but in NEXT_STEP mode
        active = ~resetting
        fractions = parse_actions(actions, self.single_action_space, self.num_envs, active)
        commands = fractions * self._max_command  # speed m/s, turn rate rad/s
        # NEXT_STEP: the sub-envs that ended last step start anew in this step's calls.
        starting = np.flatnonzero(resetting).tolist()
        self._advance(commands, active, starting)
        self._elapsed += active
        stepped = np.flatnonzero(active).tolist()
        self._pictures.advance(stepped)
        terminated = core.terminated & active
        truncated = np.zeros(self.num_envs, dtype=bool)
        if self.max_episode_steps is not None:
            truncated = (self._elapsed >= self.max_episode_steps) & active
        rewards = np.where(active, core.rewards, 0.0)
        done = terminated | truncated
        self._finish_resets(starting)
        final: dict[str, Any] | None = None
        if mode == AutoresetMode.SAME_STEP:
            self._autoreset = np.zeros(self.num_envs, dtype=bool)
            if done.any():  # the ended sub-envs start anew now
                final = self._final(done)
                ended = np.flatnonzero(done).tolist()
                self._advance(self._idle, ~self._all, ended)
                self._finish_resets(ended)
        else:
            self._autoreset = done
        info, masks = core.infos()
        infos = with_masks(info, self._all.copy(), masks)
        if final is not None:
            infos.update(final)
        return core.observations(), rewards, terminated, truncated, infos

    def _final(self, done: np.ndarray) -> dict[str, Any]:
        """``final_obs`` and ``final_info`` of the sub-envs that ended, as Gymnasium's
        SAME_STEP vector envs report them."""
        final_obs = np.full(self.num_envs, None, dtype=object)
        for b in np.flatnonzero(done).tolist():
            final_obs[b] = self.core.observation(b)
        info, masks = self.core.infos()
        final_info = with_masks(_select(info, done), done, masks)
        return {
            "final_obs": final_obs,
            "_final_obs": done.copy(),
            "final_info": final_info,
            "_final_info": done.copy(),
        }

    def render(self) -> tuple[np.ndarray, ...] | None:
        """A frame per sub-env, (H, W, 3) uint8 each: pixel for pixel the single env's
        ``render()`` of the same state (the world, the paths, the visible region cut by
        what occludes it, the step, and over a belief its estimated path and live
        figures). ``close()`` releases the renderers; a later ``render()`` makes new
        ones."""
        if self.render_mode is None:
            logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' to "
                "gym.make_vec"
            )
            return None
        if not self._started:
            raise ResetNeeded("call reset() before render()")
        pictures = self._pictures
        infos = self.core.infos()  # once for the live figures of every sub-env
        return tuple(
            pictures.render(b, pictures.belief_overlay(b, infos)) for b in range(self.num_envs)
        )

    def close_extras(self, **kwargs: Any) -> None:
        if not hasattr(self, "_pictures"):
            # A constructor that refused its arguments: nothing to close (gymnasium
            # 1.2's VectorEnv.__del__ closes such a half-made env).
            return
        self.core.close()
        self._pictures.close()

    def _index(self, index: Any) -> int:
        """``index`` as a sub-env's index, negative ones counted from the end as Python
        sequences count them; ``TypeError`` for a non-integer, ``IndexError`` out of
        range."""
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise TypeError(
                f"a sub-env index must be an integer, got {type(index).__name__} {index!r}"
            )
        b = self.num_envs
        if not -b <= index < b:
            raise IndexError(
                f"sub-env index {index} out of range: this vector env has {b} sub-envs, "
                f"indices -{b} to {b - 1}"
            )
        return int(index) % b


class LandmarksVectorEnv(SlamVectorEnv):
    """The native vector env of ``slam_env/Landmarks-v0`` (see :class:`SlamVectorEnv`;
    the sub-envs are :class:`slam_env.envs.landmarks.LandmarksEnv`)."""

    def __init__(self, num_envs: int, **kwargs: Any) -> None:
        super().__init__(num_envs, raw_core, **kwargs)


class ActiveSLAMVectorEnv(SlamVectorEnv):
    """The native vector env of ``slam_env/ActiveSLAM-v0`` (see :class:`SlamVectorEnv`;
    the sub-envs are :class:`slam_env.envs.active_slam.ActiveSLAMEnv`, with the same
    options)."""

    def __init__(self, num_envs: int, **kwargs: Any) -> None:
        super().__init__(num_envs, active_core, **kwargs)

    def filter(self, index: int) -> EKFSLAM:
        """Sub-env ``index``'s EKF-SLAM filter (its state is the vector env's; a view,
        which follows the sub-env). ``index`` counts as Python sequences count:
        ``filter(-1)`` is the last sub-env's; ``IndexError`` outside ``-B … B - 1``,
        ``TypeError`` for a non-integer."""
        return self.core.filter(self._index(index))

    def smoother(self, index: int) -> ISAM2SLAM:
        """Sub-env ``index``'s smoothing belief (``belief="isam2"``; ``ValueError``
        with the EKF's), indexed as :meth:`filter`."""
        return self.core.smoother(self._index(index))
