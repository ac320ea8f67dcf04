"""Pictures: the pygame renderer (the only module that imports pygame, and only when it
draws), the matplotlib plots (:mod:`.plots`, imported on their own), and the sensor's
visible region they draw."""

from slam_env.render.renderer import Frame, Renderer

__all__ = ["Frame", "Renderer"]
