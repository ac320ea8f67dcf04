"""Layout files: dict/JSON/YAML round trips and the errors that name the file."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
import yaml

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.config import WorldConfig
from slam_env.world.layout_files import layout_from_dict, layout_to_dict, load_layout
from slam_env.world.layout_generators import random_layout
from tests.world.layout_samples import R, make


def test_dict_round_trip_is_exact() -> None:
    layout = make(name="demo", start_pose=(1.0, 1.5, 0.25))
    d = layout_to_dict(layout)
    assert layout_from_dict(d) == layout
    assert json.loads(json.dumps(d)) == d  # plain JSON types


def test_json_and_yaml_files_round_trip(tmp_path) -> None:
    layout = random_layout(WorldConfig(), R, np.random.default_rng(3))
    jpath = tmp_path / "world.json"
    jpath.write_text(json.dumps(layout_to_dict(layout)))
    assert load_layout(jpath) == layout
    assert load_layout(str(jpath)) == layout
    for name in ("world.yaml", "world.yml"):
        ypath = tmp_path / name
        ypath.write_text(yaml.safe_dump(layout_to_dict(layout)))
        assert load_layout(ypath) == layout
    bad = tmp_path / "world.txt"
    bad.write_text("{}")
    with pytest.raises(ValueError, match=r"\.json, \.yaml or \.yml"):
        load_layout(bad)
    listy = tmp_path / "list.yaml"
    listy.write_text("- 1\n- 2\n")
    with pytest.raises(TypeError, match="mapping"):
        load_layout(listy)


def test_from_dict_accepts_point_lists_boxes_and_defaults() -> None:
    layout = layout_from_dict(
        {
            "width": 10,
            "height": 8,
            "landmarks": [[2, 2], [8, 6]],
            "obstacles": [{"box": [5, 4, 2, 1]}, [[1, 5], [1, 7], [2, 7]]],
            "walls": [[7, 1, 7, 3]],
        }
    )
    assert layout.landmark_ids == (0, 1)
    assert layout.obstacles[0] == ((4.0, 3.5), (6.0, 3.5), (6.0, 4.5), (4.0, 4.5))
    assert layout.obstacles[1] == ((2.0, 7.0), (1.0, 7.0), (1.0, 5.0))  # now CCW
    assert layout.start_pose == (1.0, 1.0, 0.0)
    assert layout.name == "custom"
    layout.validate(R)
    assert load_layout(layout) is layout


@pytest.mark.parametrize(
    ("d", "exc", "match"),
    [
        ({"width": 5, "height": 5, "colour": 1, "size": 2}, ValueError, "'colour', 'size'"),
        ({"height": 5}, ValueError, "missing 'width'"),
        ({"width": "5", "height": 5}, TypeError, "width"),
        ({"width": 5, "height": 5, "landmarks": 3}, TypeError, "landmarks"),
        ({"width": 5, "height": 5, "landmarks": [{"id": 0, "x": 1}]}, ValueError, "missing: y"),
        (
            {"width": 5, "height": 5, "landmarks": [{"id": 0, "x": 1, "y": 1, "z": 0}]},
            ValueError,
            "unknown: z",
        ),
        (
            {"width": 5, "height": 5, "landmarks": [{"id": "a", "x": 1, "y": 1}]},
            TypeError,
            "id",
        ),
        (
            {"width": 5, "height": 5, "landmarks": [{"id": 0, "x": 1, "y": 1}, [2, 2]]},
            ValueError,
            "mixes",
        ),
        ({"width": 5, "height": 5, "landmarks": [[1, 2, 3]]}, ValueError, "2 numbers"),
        ({"width": 5, "height": 5, "obstacles": [{"circle": 1}]}, ValueError, "circle"),
        ({"width": 5, "height": 5, "obstacles": [{"box": [1, 1, 0, 1]}]}, ValueError, "> 0"),
        ({"width": 5, "height": 5, "obstacles": [{"box": [1, 1, "2", 1]}]}, TypeError, "box"),
        ({"width": 5, "height": 5, "walls": [[0, 0, 1]]}, ValueError, "4 numbers"),
        ({"width": 5, "height": 5, "start": "here"}, TypeError, "start"),
        ({"width": 5, "height": 5, "name": 7}, TypeError, "name"),
        ([1, 2], TypeError, "mapping"),
    ],
)
def test_from_dict_errors(d, exc, match) -> None:
    with pytest.raises(exc, match=match):
        layout_from_dict(d)


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("bad.yaml", "width: 10\nheight: [1,\nstart: 3\n", r"bad\.yaml', line 4: not valid YAML"),
        ("bad.json", '{"width": 10,\n "height": }', r"bad\.json', line 2: not valid JSON"),
        ("binary.yaml", b"\xff\xfe\x00", r"binary\.yaml' cannot be read: 'utf-8' codec"),
        ("missing.yaml", None, r"missing\.yaml' cannot be read: No such file"),
        ("folder.yml", "dir", r"folder\.yml' cannot be read: Is a directory"),
        (
            "short.json",
            '{"width": 5, "height": 5, "start": [1, 1]}',
            r"short\.json': layout 'start'",
        ),
    ],
)
def test_layout_file_errors_name_the_file(tmp_path, name, content, message) -> None:
    path = tmp_path / name
    if content == "dir":
        path.mkdir()
    elif isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content)
    with pytest.raises(ValueError, match=message):
        load_layout(path)
    # The env reports it the same way, before building anything.
    with pytest.raises(ValueError, match=message):
        gym.make("slam_env/Landmarks-v0", layout=str(path))
