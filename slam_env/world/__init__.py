"""The world: layouts (the type, generators, presets, files), the pymunk world and B of
them as arrays, the robots' drive, and frames."""

from slam_env.world.frames import robot_to_world, world_to_robot, wrap_angle
from slam_env.world.layout_files import layout_from_dict, layout_to_dict, load_layout
from slam_env.world.layout_generators import layout_for, preset_layout, random_layout
from slam_env.world.layouts import LANDMARK_POST_RADIUS, Layout
from slam_env.world.pymunk_world import World

__all__ = [
    "LANDMARK_POST_RADIUS",
    "Layout",
    "World",
    "layout_for",
    "layout_from_dict",
    "layout_to_dict",
    "load_layout",
    "preset_layout",
    "random_layout",
    "robot_to_world",
    "world_to_robot",
    "wrap_angle",
]
