"""Layouts as dicts and JSON/YAML files (a user's own world).

:func:`layout_from_dict` / :func:`layout_to_dict` / :func:`load_layout` read and write
the dict schema (JSON/YAML)::

    {"name": "demo", "width": 10, "height": 8,
     "landmarks": [{"id": 0, "x": 2, "y": 3}, ...],   # or [[x, y], ...]: IDs 0..N-1
     "obstacles": [[[x, y], [x, y], [x, y]], {"box": [cx, cy, w, h]}, ...],
     "walls": [[x0, y0, x1, y1], ...],
     "start": [x, y, theta]}

The geometry conventions are those of :class:`~slam_env.world.layouts.Layout`.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from slam_env.world.layouts import (
    Layout,
    Point,
    as_float,
    as_float_rows,
    as_floats,
    as_int,
    as_list,
    as_polygon,
    box_polygon,
)

_DICT_KEYS = ("name", "width", "height", "landmarks", "obstacles", "walls", "start")


def _landmarks_from(value: Any) -> tuple[tuple[int, ...], tuple[Point, ...]]:
    items = as_list(value, "layout 'landmarks'")
    if not items:
        return (), ()
    as_dicts = [isinstance(it, Mapping) for it in items]
    if any(as_dicts) and not all(as_dicts):
        raise ValueError(
            "layout 'landmarks' mixes {id, x, y} entries and [x, y] pairs; use one form"
        )
    if not as_dicts[0]:
        pts = tuple(
            as_floats(p, 2, f"layout 'landmarks'[{i}]")  # type: ignore[misc]
            for i, p in enumerate(items)
        )
        return tuple(range(len(pts))), pts  # type: ignore[return-value]
    ids, pts = [], []
    for i, it in enumerate(items):
        keys = set(it)
        if keys != {"id", "x", "y"}:
            extra = sorted(map(str, keys - {"id", "x", "y"}))
            missing = sorted({"id", "x", "y"} - keys)
            raise ValueError(
                f"layout 'landmarks'[{i}] must have keys id, x, y"
                + (f"; unknown: {', '.join(extra)}" if extra else "")
                + (f"; missing: {', '.join(missing)}" if missing else "")
            )
        ids.append(as_int(it["id"], f"layout 'landmarks'[{i}].id"))
        pts.append(
            (
                as_float(it["x"], f"layout 'landmarks'[{i}].x"),
                as_float(it["y"], f"layout 'landmarks'[{i}].y"),
            )
        )
    return tuple(ids), tuple(pts)


def _obstacle_from(value: Any, k: int) -> Any:
    what = f"layout 'obstacles'[{k}]"
    if isinstance(value, Mapping):
        if set(value) != {"box"}:
            unknown = sorted(map(str, set(value) - {"box"}))
            raise ValueError(
                f"{what} must be a vertex list or {{'box': [cx, cy, w, h]}}"
                + (f"; unknown keys: {', '.join(unknown)}" if unknown else "")
            )
        cx, cy, w, h = as_floats(value["box"], 4, f"{what}.box")
        if not (w > 0 and h > 0):
            raise ValueError(f"{what}.box needs width and height > 0, got w={w}, h={h}")
        return box_polygon(cx, cy, w, h)
    return as_polygon(value, what)


def layout_from_dict(d: Mapping[str, Any]) -> Layout:
    """Build a :class:`Layout` from the dict schema in the module docstring. Unknown keys
    raise ``ValueError`` naming them; values of the wrong type raise ``TypeError``.
    ``width`` and ``height`` are required; ``start`` defaults to (1, 1, 0). The result is
    not yet checked against a robot: call :meth:`Layout.validate`."""
    if not isinstance(d, Mapping):
        raise TypeError(f"a layout must be a mapping, got {type(d).__name__}")
    unknown = [k for k in d if k not in _DICT_KEYS]
    if unknown:
        raise ValueError(
            f"unknown layout key(s): {', '.join(map(repr, unknown))}; valid keys: "
            f"{', '.join(_DICT_KEYS)}"
        )
    for key in ("width", "height"):
        if key not in d:
            raise ValueError(f"layout is missing {key!r}")
    ids, pts = _landmarks_from(d.get("landmarks", []))
    obstacles = tuple(
        _obstacle_from(o, k)
        for k, o in enumerate(as_list(d.get("obstacles", []), "layout 'obstacles'"))
    )
    walls = as_float_rows(d.get("walls", []), 4, "layout 'walls'")
    kwargs: dict[str, Any] = {}
    if "start" in d:
        kwargs["start_pose"] = as_floats(d["start"], 3, "layout 'start'")
    if "name" in d:
        if not isinstance(d["name"], str):
            raise TypeError(f"layout 'name' must be a str, got {type(d['name']).__name__}")
        kwargs["name"] = d["name"]
    return Layout(
        width=as_float(d["width"], "layout 'width'"),
        height=as_float(d["height"], "layout 'height'"),
        landmark_ids=ids,
        landmark_positions=pts,
        obstacles=obstacles,
        walls=walls,
        **kwargs,
    )


def layout_to_dict(layout: Layout) -> dict[str, Any]:
    """The dict schema of ``layout`` (plain Python types, JSON/YAML ready), such that
    ``layout_from_dict(layout_to_dict(layout)) == layout``."""
    if not isinstance(layout, Layout):
        raise TypeError(f"expected a Layout, got {type(layout).__name__}")
    return {
        "name": layout.name,
        "width": layout.width,
        "height": layout.height,
        "landmarks": [
            {"id": i, "x": x, "y": y}
            for i, (x, y) in zip(layout.landmark_ids, layout.landmark_positions, strict=True)
        ],
        "obstacles": [[[x, y] for x, y in poly] for poly in layout.obstacles],
        "walls": [list(w) for w in layout.walls],
        "start": list(layout.start_pose),
    }


def load_layout(source: Layout | Mapping[str, Any] | str | os.PathLike[str]) -> Layout:
    """A :class:`Layout` from a Layout (returned as is), a dict (the schema of
    :func:`layout_from_dict`) or a ``.json``/``.yaml``/``.yml`` file path. A file that
    cannot be read or parsed raises ``ValueError`` naming it (and the line, when the
    parser knows it); so does a problem with its content (``TypeError`` for a value of
    the wrong type)."""
    if isinstance(source, Layout):
        return source
    if isinstance(source, Mapping):
        return layout_from_dict(source)
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(
            f"a layout must be a Layout, a dict or a file path, got {type(source).__name__}"
        )
    path = Path(source)
    name = repr(str(path))
    if path.suffix.lower() not in (".json", ".yaml", ".yml"):
        raise ValueError(f"layout file {name} must end in .json, .yaml or .yml")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ValueError(f"layout file {name} cannot be read: {reason}") from exc
    data = _parse_layout_text(text, path.suffix.lower(), name)
    if not isinstance(data, Mapping):
        raise TypeError(f"layout file {name} must hold a mapping, got {type(data).__name__}")
    try:
        return layout_from_dict(data)
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"layout file {name}: {exc}") from exc


def _parse_layout_text(text: str, suffix: str, name: str) -> Any:
    """The data of a layout file's text; ``ValueError`` naming the file and the line."""
    if suffix == ".json":
        try:
            return json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(
                f"layout file {name}, line {exc.lineno}: not valid JSON: {exc.msg}"
            ) from exc
    import yaml

    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f", line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ValueError(f"layout file {name}{where}: not valid YAML: {problem}") from exc
