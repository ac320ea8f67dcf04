"""A small hand-made layout for the layout tests: a square obstacle, an inner wall and
two landmarks in a 10 m square arena."""

from __future__ import annotations

from slam_env.world.layouts import Layout

R = 0.25  # m, robot radius used throughout
SQUARE = ((4.0, 4.0), (6.0, 4.0), (6.0, 6.0), (4.0, 6.0))


def make(**overrides) -> Layout:
    base = dict(
        width=10.0,
        height=10.0,
        landmark_ids=(0, 1),
        landmark_positions=((2.0, 8.0), (8.0, 8.0)),
        obstacles=(SQUARE,),
        walls=((1.0, 3.0, 3.0, 3.0),),
        start_pose=(1.0, 1.0, 0.0),
    )
    base.update(overrides)
    return Layout(**base)
