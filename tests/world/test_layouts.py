"""Layouts: construction, validation, collision queries and the geometry helpers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.world.layouts import (
    LANDMARK_POST_RADIUS,
    _polygon_problem,
    _polygon_signed_distance,
    segment_distance,
)
from tests.world.layout_samples import SQUARE, R, make


def test_valid_layout_passes_and_returns_itself() -> None:
    layout = make()
    assert layout.validate(R, clearance=0.4) is layout


# ----------------------------------------------------------------------------- invalid


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"landmark_positions": ((5.0, 5.0), (8.0, 8.0))}, "landmark ID 0 .* inside obstacle 0"),
        ({"landmark_positions": ((6.05, 5.0), (8.0, 8.0))}, "from obstacle 0, closer than"),
        ({"landmark_positions": ((2.0, 3.0), (8.0, 8.0))}, "inside wall 0"),
        ({"landmark_positions": ((2.0, 3.15), (8.0, 8.0))}, "from wall 0, closer than"),
        ({"landmark_positions": ((11.0, 5.0), (8.0, 8.0))}, "landmark ID 0 .* outside the arena"),
        ({"landmark_positions": ((-0.5, 5.0), (8.0, 8.0))}, "outside the arena"),
        ({"landmark_positions": ((0.05, 5.0), (8.0, 8.0))}, "from the arena boundary"),
        ({"landmark_positions": ((8.0, 8.0), (8.1, 8.0))}, "posts of ID 0 and ID 1 overlap"),
        ({"landmark_ids": (3, 3)}, "duplicate landmark ID 3"),
        ({"landmark_ids": (0, -2)}, "negative landmark ID -2"),
        ({"landmark_ids": (0, 1, 2)}, "landmark_ids has 3 entries but landmark_positions has 2"),
        ({"landmark_positions": ((2.0, 8.0),)}, "has 2 entries but landmark_positions has 1"),
        ({"landmark_positions": ((math.nan, 8.0), (8.0, 8.0))}, "non-finite position"),
        ({"landmark_positions": ((2.0, math.inf), (8.0, 8.0))}, "non-finite position"),
        ({"width": math.inf}, "arena size must be finite"),
        ({"height": -1.0}, "arena size must be finite and > 0"),
        ({"obstacles": (((1.0, 1.0), (2.0, math.nan), (2.0, 2.0)),)}, "obstacle 0 .*non-finite"),
        ({"walls": ((1.0, 3.0, math.inf, 3.0),)}, "wall 0 has a non-finite"),
        ({"start_pose": (1.0, 1.0, math.nan)}, "start_pose is not finite"),
        ({"obstacles": (((4.0, 4.0), (6.0, 4.0)),)}, "obstacle 0 is degenerate: .*2 vertices"),
        ({"obstacles": (((4.0, 4.0), (6.0, 4.0), (8.0, 4.0)),)}, "obstacle 0 .*zero area"),
        (
            {"obstacles": (((4.0, 4.0), (4.0, 4.0), (6.0, 4.0), (5.0, 6.0)),)},
            "obstacle 0 is degenerate: vertex 0 repeats",
        ),
        (
            # An arrowhead: a reflex vertex.
            {"obstacles": (((4.0, 4.0), (7.0, 5.0), (4.0, 6.0), (5.0, 5.0)),)},
            "obstacle 0 is not convex",
        ),
        (
            # A pentagram: every turn has the same sign, but the edges cross.
            {
                "obstacles": (
                    tuple(
                        (5.0 + math.cos(a), 5.0 + math.sin(a))
                        for a in (math.pi / 2 + k * 4 * math.pi / 5 for k in range(5))
                    ),
                )
            },
            "obstacle 0 is not convex",
        ),
        (
            {"obstacles": (((9.0, 4.0), (11.0, 4.0), (11.0, 6.0), (9.0, 6.0)),)},
            "obstacle 0 extends outside the arena",
        ),
        ({"walls": ((1.0, 3.0, 1.0, 3.0),)}, "wall 0 has zero length"),
        ({"walls": ((1.0, 3.0, 12.0, 3.0),)}, "wall 0 extends outside the arena"),
        ({"start_pose": (0.1, 1.0, 0.0)}, r"start pose .* in collision: .*arena boundary"),
        ({"start_pose": (12.0, 1.0, 0.0)}, "start pose .* outside the arena"),
        ({"start_pose": (3.8, 5.0, 0.0)}, "start pose .* overlaps obstacle 0"),
        ({"start_pose": (2.0, 3.3, 0.0)}, "start pose .* overlaps wall 0"),
        ({"start_pose": (2.0, 7.7, 0.0)}, "start pose .* post of landmark ID 0"),
    ],
)
def test_invalid_layouts_raise_naming_the_problem(overrides, match) -> None:
    with pytest.raises(ValueError, match=match):
        make(**overrides).validate(R, clearance=0.4)


def test_clearance_only_applies_when_asked() -> None:
    near = make(landmark_positions=((6.3, 5.0), (8.0, 8.0)))  # 0.3 m from the square
    near.validate(R)  # post radius only
    with pytest.raises(ValueError, match=r"0\.3 m from obstacle 0"):
        near.validate(R, clearance=0.4)


def test_wall_thickness_counts_for_start_and_landmarks() -> None:
    layout = make(start_pose=(2.0, 3.5, 0.0))  # 0.5 m from the wall's centre line
    layout.validate(R, wall_thickness=0.1)
    with pytest.raises(ValueError, match="overlaps wall 0"):
        layout.validate(R, wall_thickness=0.3)


def test_validate_rejects_bad_robot_radius() -> None:
    with pytest.raises(ValueError, match="robot_radius"):
        make().validate(0.0)
    with pytest.raises(ValueError, match="clearance"):
        make().validate(R, clearance=-1.0)


def test_wrong_types_raise_type_error() -> None:
    with pytest.raises(TypeError, match="landmark_ids"):
        make(landmark_ids=(0, 1.5))
    with pytest.raises(TypeError, match="landmark_ids"):
        make(landmark_ids=(True, 1))
    with pytest.raises(TypeError, match="width"):
        make(width="10")
    with pytest.raises(TypeError, match="name"):
        make(name=3)
    with pytest.raises(ValueError, match="start_pose must have 3 numbers"):
        make(start_pose=(1.0, 1.0))


def test_either_winding_is_accepted_and_normalised() -> None:
    cw = tuple(reversed(SQUARE))
    layout = make(obstacles=(cw,))
    layout.validate(R)
    assert layout.obstacles == make().obstacles  # counter-clockwise


def test_construction_normalises_numpy_inputs() -> None:
    layout = make(
        landmark_ids=np.array([4, 7]),
        landmark_positions=np.array([[2.0, 8.0], [8.0, 8.0]]),
        start_pose=np.array([1.0, 1.0, 0.0]),
    )
    assert layout.landmark_ids == (4, 7)
    assert all(type(i) is int for i in layout.landmark_ids)
    assert layout.landmark_positions == ((2.0, 8.0), (8.0, 8.0))
    assert all(type(c) is float for p in layout.landmark_positions for c in p)
    assert hash(layout) == hash(make(landmark_ids=(4, 7)))


def test_tuples_of_floats_are_kept_and_anything_else_coerced_or_refused() -> None:
    kept = ((2.0, 8.0), (8.0, 8.0))
    assert make(landmark_positions=kept).landmark_positions is kept  # nothing to coerce
    mixed = make(
        landmark_ids=(0, np.int64(1)),
        landmark_positions=((2, 8.0), (np.float32(8.0), 8.0)),
        obstacles=(tuple((int(x), y) for x, y in SQUARE),),
        walls=[(1, 3, 3, 3)],
    )
    assert mixed == make()
    assert all(type(v) is int for v in mixed.landmark_ids)
    assert all(type(c) is float for p in mixed.landmark_positions for c in p)
    assert all(type(c) is float for p in mixed.obstacles[0] for c in p)
    assert all(type(c) is float for c in mixed.walls[0])
    with pytest.raises(ValueError, match=r"landmark_positions\[1\] must have 2 numbers"):
        make(landmark_positions=((2.0, 8.0), (8.0, 8.0, 1.0)))
    with pytest.raises(ValueError, match=r"walls\[0\] must have 4 numbers"):
        make(walls=((1.0, 3.0, 3.0),))
    with pytest.raises(TypeError, match=r"obstacles\[0\] vertex 1"):
        make(obstacles=(((4.0, 4.0), (6.0, "4"), (6.0, 6.0)),))


def test_obstacle_bounding_boxes_span_their_vertices() -> None:
    layout = make(obstacles=(SQUARE, ((7.0, 1.0), (9.0, 2.0), (7.5, 2.5)), ()))
    assert layout._obstacle_bboxes == (
        (4.0, 4.0, 6.0, 6.0),
        (7.0, 1.0, 9.0, 2.5),
        (math.inf, math.inf, -math.inf, -math.inf),
    )


def test_geometry_helpers() -> None:
    assert segment_distance(0.0, 1.0, -1.0, 0.0, 1.0, 0.0) == pytest.approx(1.0)
    assert segment_distance(3.0, 0.0, -1.0, 0.0, 1.0, 0.0) == pytest.approx(2.0)
    assert _polygon_signed_distance(5.0, 5.0, SQUARE) == pytest.approx(-1.0)
    assert _polygon_signed_distance(7.0, 5.0, SQUARE) == pytest.approx(1.0)
    assert _polygon_signed_distance(7.0, 7.0, SQUARE) == pytest.approx(math.sqrt(2.0))


def test_collision_queries() -> None:
    layout = make()
    assert layout.is_free(1.0, 1.0, R)
    assert layout.collision_reason(3.8, 5.0, R) == "overlaps obstacle 0"
    assert layout.collision_reason(3.75, 5.0, R) is None  # touching counts as free
    assert not layout.is_free(3.75, 5.0, R, margin=0.01)


def test_post_radius_constant() -> None:
    assert pytest.approx(0.1) == LANDMARK_POST_RADIUS


def test_a_far_obstacle_is_not_taken_for_a_degenerate_one() -> None:
    """Degeneracy is judged on the polygon's own size, wherever it lies."""
    box = ((5e8, 5e8), (5e8 + 1.0, 5e8), (5e8 + 1.0, 5e8 + 1.0), (5e8, 5e8 + 1.0))
    assert _polygon_problem(box) is None
    assert "zero area" in _polygon_problem(((5e8, 5e8), (5e8 + 1.0, 5e8), (5e8 + 2.0, 5e8)))
    assert "repeats" in _polygon_problem(((5e8, 5e8), (5e8, 5e8), (5e8 + 1.0, 5e8 + 1.0)))
