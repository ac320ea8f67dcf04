"""The sensor's visible region: traced with the world's range query, it matches what the
landmark sensor detects, and the movie draws it clipped."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from matplotlib.path import Path as PolygonPath

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.render.renderer import COLORS, Frame, Renderer
from slam_env.render.visibility import RAY_SPACING, sensor_ray_angles, visible_region
from slam_env.world.layouts import LANDMARK_POST_RADIUS, Layout

FOV = 2.0 * math.pi / 3.0
# A point this far in front of a landmark's post stands for the landmark: the ray
# along its line of sight stops at the post itself.
IN_FRONT = LANDMARK_POST_RADIUS + 0.05


def inside(region: np.ndarray, point) -> bool:
    return bool(PolygonPath(region).contains_point(point))


def in_front_of(pose, landmark) -> np.ndarray:
    """The point on the line of sight from ``pose`` to ``landmark``, just short of its post."""
    offset = np.asarray(landmark, float) - np.asarray(pose[:2], float)
    d = float(np.hypot(*offset))
    return np.asarray(pose[:2], float) + offset * (d - IN_FRONT) / d


def test_ray_angles_cover_the_field_of_view():
    angles = np.array(sensor_ray_angles(FOV))
    assert angles[0] == pytest.approx(-FOV / 2) and angles[-1] == pytest.approx(FOV / 2)
    assert np.all(np.diff(angles) > 0) and np.diff(angles).max() <= RAY_SPACING + 1e-12
    around = np.array(sensor_ray_angles(2.0 * math.pi, math.radians(10)))
    assert around.size == 36 and around[0] == -math.pi  # a circle, its end not repeated
    assert np.diff(around) == pytest.approx(np.full(35, math.radians(10)))
    with pytest.raises(ValueError, match="fov"):
        sensor_ray_angles(0.0)
    with pytest.raises(ValueError, match="spacing"):
        sensor_ray_angles(FOV, math.nan)


def test_ray_angles_at_their_limits():
    # A wedge narrower than the spacing: its two edges only.
    assert sensor_ray_angles(0.01, math.radians(1.0)) == pytest.approx((-0.005, 0.005))
    # All around with a coarse spacing: still 8 rays, 45° apart.
    around = sensor_ray_angles(2.0 * math.pi, 2.0)
    assert len(around) == 8 and np.diff(around) == pytest.approx(np.full(7, math.pi / 4))
    # The default spacing is 1°, fine enough for a post several metres away.
    assert pytest.approx(math.radians(1.0)) == RAY_SPACING
    with pytest.raises(ValueError, match="spacing"):
        sensor_ray_angles(FOV, 0.0)


def test_a_short_range_is_a_valid_range():
    class OpenWorld:
        def range_scan(self, x, y, theta, angles, max_range):
            return [max_range] * len(angles)

    region = visible_region(OpenWorld(), (0.0, 0.0, 0.0), 0.5, math.pi / 2)
    assert region[0] == pytest.approx([0.0, 0.0])
    assert np.hypot(*region[1:].T) == pytest.approx(np.full(len(region) - 1, 0.5))
    with pytest.raises(ValueError, match="max_range"):
        visible_region(OpenWorld(), (0.0, 0.0, 0.0), 0.0, math.pi / 2)


# Landmark 0 hides behind the box, 3 behind landmark 1's post; 1 and 2 are in view,
# 4 is in range but behind the robot.
HIDE_AND_SEEK = Layout(
    width=10.0,
    height=8.0,
    landmark_ids=(0, 1, 2, 3, 4),
    landmark_positions=((6.0, 4.0), (4.0, 6.0), (3.5, 2.5), (4.75, 6.5), (0.5, 6.0)),
    obstacles=(((3.5, 3.5), (4.5, 3.5), (4.5, 4.5), (3.5, 4.5)),),
    start_pose=(1.0, 4.0, 0.0),
)


def test_a_landmark_behind_an_obstacle_lies_outside_the_region():
    env = gym.make("slam_env/Landmarks-v0", layout=HIDE_AND_SEEK)
    env.reset(seed=0)
    frame = env.unwrapped.render_frame()
    pose = frame.pose
    assert set(frame.detected_ids.tolist()) == {1, 2}
    region = frame.visible_region
    positions = dict(zip(HIDE_AND_SEEK.landmark_ids, HIDE_AND_SEEK.landmark_positions, strict=True))
    for i in (1, 2):  # detected: the region reaches their posts
        assert inside(region, in_front_of(pose, positions[i])), i
    for i in (0, 3, 4):  # behind the box, behind a post, behind the robot
        assert not inside(region, positions[i]), i
        assert not inside(region, in_front_of(pose, positions[i])), i
    # In front of the box the region is open; beyond it, in its shadow, it is not.
    assert inside(region, (3.0, 4.0)) and not inside(region, (5.0, 4.0))
    # All around, the ray ends alone enclose the region: the box's shadow, and the
    # robot inside it.
    world = env.unwrapped.world
    around = visible_region(world, pose, 5.0, 2.0 * math.pi)
    assert np.all(np.hypot(*(around - pose[:2]).T) <= 5.0 + 1e-9)
    assert inside(around, pose[:2]) and inside(around, in_front_of(pose, positions[4]))
    assert not inside(around, (5.0, 4.0))
    env.close()


def _grazing(world, pose, landmark_index: int, landmark) -> bool:
    """Whether the line of sight changes within a ray's spacing of the landmark's
    bearing: there the region, drawn between rays, may differ from the sensor."""
    x, y = pose[:2]
    dx, dy = landmark[0] - x, landmark[1] - y
    clear = set()
    for turn in (-1.5 * RAY_SPACING, 0.0, 1.5 * RAY_SPACING):
        c, s = math.cos(turn), math.sin(turn)
        target = (x + c * dx - s * dy, y + s * dx + c * dy)
        clear.add(world.line_of_sight((x, y), target, landmark_index))
    return len(clear) > 1


def test_the_region_matches_the_detections_on_random_worlds():
    env = gym.make("slam_env/Landmarks-v0", n_obstacles=10, n_landmarks=25)
    rng = np.random.default_rng(7)
    checked = hidden = 0
    for seed in range(12):
        env.reset(seed=seed)
        base = env.unwrapped
        for _ in range(4):
            for _ in range(15):
                env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32))
            frame = base.render_frame()
            world, pose = base.world, np.asarray(frame.pose)
            detected = set(frame.detected_ids.tolist())
            for k, (i, landmark) in enumerate(
                zip(world.landmark_ids.tolist(), world.landmark_positions, strict=True)
            ):
                offset = landmark - pose[:2]
                d = float(np.hypot(*offset))
                bearing = math.remainder(math.atan2(offset[1], offset[0]) - pose[2], math.tau)
                in_view = d <= base.config.sensor.max_range - 0.01
                in_view &= abs(bearing) <= FOV / 2 - 1.5 * RAY_SPACING
                if not in_view or d < 2 * IN_FRONT or _grazing(world, pose, k, landmark):
                    continue
                seen = inside(frame.visible_region, in_front_of(pose, landmark))
                assert seen == (i in detected), (seed, i)
                checked += 1
                hidden += i not in detected
    assert checked > 80 and hidden > 15  # both cases were tested, many times
    env.close()


# ---------------------------------------------------------------------- the movie
def test_the_movie_draws_the_region_clipped(layout):
    renderer = Renderer(layout, 0.25, 5.0, FOV, "rgb_array")
    pose = (1.0, 4.0, 0.0)
    # A region that the sensor's full wedge would cover, cut short at x = 3 m.
    region = np.array([[1.0, 4.0], [3.0, 2.5], [3.0, 5.5]])
    clipped = renderer.render(Frame(pose=pose, visible_region=region))
    wedge = renderer.render(Frame(pose=pose))
    inner, shadow = renderer.world_to_pixel([(2.5, 4.0), (4.0, 4.0)]).round().astype(int)
    floor = np.array(COLORS["floor"])
    assert np.any(clipped[inner[1], inner[0]] != floor)  # tinted inside the region
    np.testing.assert_array_equal(clipped[shadow[1], shadow[0]], floor)  # not beyond it
    assert np.any(wedge[shadow[1], shadow[0]] != floor)  # which the bare wedge covers
    renderer.close()


def test_the_env_movie_shows_the_shadow_of_an_obstacle():
    env = gym.make("slam_env/Landmarks-v0", layout=HIDE_AND_SEEK, render_mode="rgb_array")
    env.reset(seed=0)
    img = env.render()
    renderer = env.unwrapped._renderer
    floor = np.array(COLORS["floor"])
    lit, shaded = renderer.world_to_pixel([(3.0, 4.6), (5.5, 4.0)]).round().astype(int)
    assert np.any(img[lit[1], lit[0]] != floor)
    np.testing.assert_array_equal(img[shaded[1], shaded[0]], floor)
    env.close()
