"""The small world the World tests drive and look around in, pymunk's own occlusion
test they compare the compiled one with, and a space that counts its point queries."""

from __future__ import annotations

import pymunk

from slam_env.config import RobotConfig
from slam_env.world.layouts import Layout
from slam_env.world.pymunk_world import _ALL, CAT_ROBOT, World

ROBOT = RobotConfig()  # radius 0.25 m, max speed 1 m/s
R = ROBOT.radius
DT, SUBSTEPS, T = 0.2, 4, 0.1

BOX = ((6.0, 6.0), (7.0, 6.0), (7.0, 7.0), (6.0, 7.0))


def arena(**overrides) -> Layout:
    """10 × 10 m: an inner wall x = 5 (y from 1 to 4), a box, three landmarks."""
    base = dict(
        width=10.0,
        height=10.0,
        landmark_ids=(10, 11, 12),
        landmark_positions=((8.0, 2.0), (8.0, 9.0), (2.0, 9.0)),
        obstacles=(BOX,),
        walls=((5.0, 1.0, 5.0, 4.0),),
        start_pose=(2.0, 2.5, 0.0),
    )
    base.update(overrides)
    return Layout(**base)


def world(layout: Layout | None = None, robot: RobotConfig = ROBOT) -> World:
    return World(layout or arena(), robot, DT, SUBSTEPS, T)


def pymunk_sees(w: World, origin, target, landmark_index: int) -> bool:
    """The occlusion test asked of pymunk's public API: a segment query that skips the
    robot and the landmark's own post (its shape filter group is index + 1)."""
    query_filter = pymunk.ShapeFilter(group=landmark_index + 1, mask=_ALL & ~CAT_ROBOT)
    o, t = (float(origin[0]), float(origin[1])), (float(target[0]), float(target[1]))
    return w.space.segment_query_first(o, t, 0.0, query_filter) is None


class CountingSpace:
    """A pymunk space that counts its point queries."""

    def __init__(self, space: pymunk.Space) -> None:
        self.space = space
        self.queries = 0

    def point_query_nearest(self, *args):
        self.queries += 1
        return self.space.point_query_nearest(*args)
