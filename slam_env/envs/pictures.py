"""What the pictures of a batched core's sub-envs draw beyond the core's state, and
their renderers: one :class:`Pictures` for the single env (B = 1) and for the native
vector env (B sub-envs), so that a sub-env's frame is built by one code path, whichever
env draws it, and ``venv.render()[i]`` is the single env's ``render()``."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from slam_env.belief.overlay import BeliefOverlay
from slam_env.render.renderer import Frame, Renderer
from slam_env.world.layouts import Layout

__all__ = ["LIVE_FIGURES", "Pictures"]

#: The belief's figures (``info`` keys) shown live beside the rendered map.
LIVE_FIGURES = ("entropy", "map_rmse", "pose_nees")


class Pictures:
    """The pictures of the sub-envs of ``core`` (a :class:`~slam_env.core.raw.RawCore`
    or an :class:`~slam_env.core.active.ActiveCore`): each sub-env's true path (and,
    over a belief, its estimated path), kept only when ``render_mode`` is set, its
    steps since its reset, and its :class:`~slam_env.render.renderer.Renderer`, made
    at its first frame and kept for the env's life (its canvas keeps the size of the
    first world it drew).

    The env calls :meth:`restart` for the sub-envs that start an episode and
    :meth:`advance` for those that step; :meth:`frame` and :meth:`render` then draw a
    sub-env as it is now: the core's state (:meth:`RawCore.frame
    <slam_env.core.raw.RawCore.frame>`: the robot, the detections, the visible region)
    with the paths, the step and the belief's live figures.
    """

    def __init__(self, core: Any, render_mode: str | None, render_fps: int) -> None:
        self.core = core
        self.render_mode = render_mode
        self.render_fps = render_fps
        b = core.num_envs
        self.trails: list[list[tuple[float, float]]] = [[] for _ in range(b)]
        self.estimated: list[list[tuple[float, float]]] = [[] for _ in range(b)]
        self.steps = np.zeros(b, dtype=np.int64)
        self.renderers: list[Renderer | None] = [None] * b
        self._belief = core.has_belief

    # ------------------------------------------------------------------ the paths
    def restart(self, rows: Sequence[int]) -> None:
        """The sub-envs ``rows`` start an episode (after the core's reset): their step
        counts start at 0, their paths where they are, their renderers draw the new
        world."""
        self.steps[rows] = 0
        if self.render_mode is None:
            return
        for b in rows:
            self.trails[b] = []
            self.estimated[b] = []
            self._remember(b)
            self.set_layout(b, self.core.layout(b))

    def advance(self, rows: Sequence[int]) -> None:
        """The sub-envs ``rows`` took a step (after the core's): their paths reach
        where they are now."""
        self.steps[rows] += 1
        if self.render_mode is not None:
            for b in rows:
                self._remember(b)

    def _remember(self, index: int) -> None:
        """Sub-env ``index``'s true (and estimated) position, for its paths."""
        pose = self.core.true_pose(index)
        self.trails[index].append((float(pose[0]), float(pose[1])))
        if self._belief:
            x, y = self.core.filter(index).pose[:2].tolist()
            self.estimated[index].append((x, y))

    # ------------------------------------------------------------------ the frames
    def belief_overlay(
        self, index: int, infos: tuple[dict[str, Any], dict[str, np.ndarray]] | None = None
    ) -> BeliefOverlay | None:
        """Sub-env ``index``'s belief as drawn (None over the raw core): the core's
        overlay with the estimated path and the live figures of :data:`LIVE_FIGURES`
        that its info reports (``infos``: the core's ``infos()``, if at hand)."""
        if not self._belief:
            return None
        overlay = self.core.belief_overlay(index)
        stacked, masks = self.core.infos() if infos is None else infos
        overlay.trail = np.array(self.estimated[index], dtype=np.float64).reshape(-1, 2)
        overlay.figures = {
            name: stacked[name].item(index)  # as info_row gives the single env's info
            for name in LIVE_FIGURES
            if name in stacked and (name not in masks or masks[name][index])
        }
        return overlay

    def frame(self, index: int, belief: BeliefOverlay | None) -> Frame:
        """The :class:`~slam_env.render.renderer.Frame` of sub-env ``index`` now, with
        ``belief`` drawn over it (see :meth:`belief_overlay`)."""
        frame = self.core.frame(index, self.trails[index], belief)
        frame.step = int(self.steps[index])
        return frame

    def render(self, index: int, belief: BeliefOverlay | None) -> np.ndarray | None:
        """Draw sub-env ``index``'s :meth:`frame` with its renderer: an (H, W, 3)
        uint8 array in ``"rgb_array"`` mode, None in ``"human"`` mode."""
        return self.renderer(index).render(self.frame(index, belief))

    def renderer(self, index: int) -> Renderer:
        """Sub-env ``index``'s renderer, made at the first call."""
        renderer = self.renderers[index]
        if renderer is None:
            cfg = self.core.config
            renderer = self.renderers[index] = Renderer(
                self.core.layout(index),
                robot_radius=cfg.robot.radius,
                max_range=cfg.sensor.max_range,
                fov=cfg.sensor.fov,
                render_mode=self.render_mode,
                render_fps=self.render_fps,
            )
        return renderer

    def set_layout(self, index: int, layout: Layout) -> None:
        """Sub-env ``index``'s world changed mid-episode (moved landmarks)."""
        renderer = self.renderers[index]
        if renderer is not None:
            renderer.set_layout(layout)

    def close(self) -> None:
        """Release the renderers (windows, surfaces); the paths stay, and the next
        frame makes a renderer anew."""
        for renderer in self.renderers:
            if renderer is not None:
                renderer.close()
        self.renderers = [None] * len(self.renderers)

    # Pickling: renderers (pygame surfaces, a window) stay behind, rebuilt on demand.
    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["renderers"] = [None] * len(self.renderers)
        return state
