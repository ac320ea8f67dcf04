"""The env pages of the docs, generated from the code as Gymnasium generates its own
(they are committed too, and a test checks they are current):
each env class's docstring (its fixed sections), its spaces, and the tables of
options (:mod:`slam_env.config`, :class:`slam_env.core.active_options.ActiveSLAMOptions`)
and info keys (:mod:`slam_env.info_keys`). Sphinx runs :func:`write_pages` before it
reads the sources; ``python docs/_ext/env_pages.py`` writes them by hand.
"""

from __future__ import annotations

import dataclasses
import inspect
import re
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
PAGES = HERE.parent / "envs"
SECTIONS = {
    "world": "The world",
    "robot": "The robot",
    "sensor": "The sensors",
    "odometry": "Odometry",
    "reward": "The raw env's reward",
    "faults": "Faults",
}


def _myst(text: str) -> str:
    """A docstring's reST inline markup as MyST's: ``x`` → `x`, :role:`t` → {role}`t`."""
    text = re.sub(r"``([^`]+)``", r"`\1`", text)
    return re.sub(r":(\w+(?::\w+)?):`([^`]+)`", r"{\1}`\2`", text)


def _cell(text: Any) -> str:
    return _myst(str(text)).replace("|", "\\|").replace("\n", " ")


def _docstring_sections(cls: type) -> list[tuple[str, str]]:
    """(heading, body) of the ``## Heading`` sections of a class docstring; the text
    before the first heading comes as ('', summary)."""
    doc = inspect.cleandoc(cls.__doc__ or "")
    parts = re.split(r"^## (.+)$", doc, flags=re.M)
    out = [("", parts[0].strip())]
    out += [(parts[i].strip(), parts[i + 1].strip()) for i in range(1, len(parts), 2)]
    return out


def _default(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, tuple):
        return "(" + ", ".join(_default(v) for v in value) + ")"
    return repr(value)


def option_rows(table: type, overrides: dict[str, Any] | None = None) -> list[str]:
    """The rows of one option table: name, default, unit, limits, meaning."""
    from slam_env.config import limits_text

    overrides = overrides or {}
    rows = []
    for f in dataclasses.fields(table):
        if not f.init or "doc" not in f.metadata:
            continue
        default = overrides.get(f.name, f.default)
        mark = " (here)" if f.name in overrides else ""
        rows.append(
            f"| `{f.name}` | `{_default(default)}`{mark} | {_cell(f.metadata['unit'])} "
            f"| {_cell(limits_text(f))} | {_cell(f.metadata['doc'])} |"
        )
    return rows


def options_markdown(active: bool) -> str:
    """The option tables of an ID, as Markdown."""
    from slam_env import config
    from slam_env.belief.reward import ActiveSLAMRewardWeights
    from slam_env.core.active_options import ACTIVE_SLAM_DEFAULTS, ActiveSLAMOptions

    head = "| option | default | unit | limits | meaning |\n|---|---|---|---|---|"
    out = []
    if active:
        out += [
            "### The belief's options",
            "",
            head,
            *option_rows(ActiveSLAMOptions),
            "",
            "`reward_weights` takes these fields (an `ActiveSLAMRewardWeights` or a dict):",
            "",
            head,
            *option_rows(ActiveSLAMRewardWeights),
            "",
        ]
    overrides = ACTIVE_SLAM_DEFAULTS if active else {}
    classes = {f.name: f.default_factory for f in dataclasses.fields(config.EnvConfig)}
    for section, title in SECTIONS.items():
        cls = classes[section]
        out += [
            f"### {title} (`{section}`)",
            "",
            _myst(inspect.cleandoc(cls.__doc__)),
            "",
            head,
            *option_rows(cls, overrides),
            "",
        ]
    out += ["### The env's own", "", head, *option_rows(config.EnvConfig), ""]
    return "\n".join(out)


def info_markdown(active: bool) -> str:
    from slam_env.info_keys import ACTIVE_INFO, RAW_INFO

    rows = [
        f"| `{k.name}` | {_cell(k.meaning)} | {_cell(k.unit)} | {_cell(k.when)} |"
        for k in (ACTIVE_INFO if active else RAW_INFO)
    ]
    return "\n".join(["| key | meaning | unit | when |", "|---|---|---|---|", *rows])


def env_page(env_id: str) -> str:
    """The Markdown page of ``env_id`` (``slam_env/Landmarks-v0`` or
    ``slam_env/ActiveSLAM-v0``)."""
    import gymnasium as gym

    import slam_env  # noqa: F401  (registers the IDs)

    spec = gym.spec(env_id)
    env = gym.make(env_id)
    cls = type(env.unwrapped)
    active = env_id.endswith("ActiveSLAM-v0")
    sections = dict(_docstring_sections(cls))
    summary = sections.pop("")
    lines = [
        f"# `{env_id}`",
        "",
        "<!-- Generated from the code by docs/_ext/env_pages.py: edit the code, not this. -->",
        "",
        _myst(summary),
        "",
        "| | |",
        "|---|---|",
        f'| make | `gym.make("{env_id}")` |',
        f'| vector | `gym.make_vec("{env_id}", num_envs=B, '
        'vectorization_mode="vector_entry_point", num_threads=T)`: the compiled '
        "stages of the B sub-envs in T chunks on T threads (default: the cores the "
        "process may use, at most B // 64 and at least 1; the same streams for every T; see [the "
        "vector env](../vector.md)) |",
        f"| class | {{class}}`{cls.__module__}.{cls.__name__}` |",
        f"| action space | `{_cell(env.action_space)}` |",
        f"| observation space | `{_cell(_space_summary(env.observation_space))}` |",
        f"| episode | {spec.max_episode_steps} steps (`max_episode_steps`) |",
        "",
        "```python",
        "import gymnasium as gym",
        "",
        "import slam_env  # registers the IDs",
        "",
        f'env = gym.make("{env_id}")',
        "obs, info = env.reset(seed=0)",
        "for _ in range(100):",
        "    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())",
        "```",
        "",
    ]
    for heading, body in sections.items():
        lines += [f"## {heading}", "", _myst(body), ""]
        if heading == "Arguments":
            lines += [
                'Each option is given flat (`fov=2.5`) or in its section (`sensor={"fov": '
                "2.5}`); the defaults marked *(here)* are this ID's own.",
                "",
                options_markdown(active),
                "",
            ]
        if heading == "Info":
            lines += [info_markdown(active), ""]
    env.close()
    return "\n".join(lines).rstrip() + "\n"


def _space_summary(space: Any) -> str:
    if hasattr(space, "spaces"):
        inner = ", ".join(f"{k}: {v.shape}" for k, v in space.spaces.items())
        return f"Dict({inner}) float32"
    return f"Box({space.shape}) {space.dtype}"


def write_pages(*_: Any) -> list[Path]:
    """Write ``docs/envs/landmarks.md`` and ``docs/envs/active_slam.md`` (a Sphinx
    ``builder-inited`` handler, or a plain call); returns their paths."""
    PAGES.mkdir(exist_ok=True)
    written = []
    for env_id, name in (
        ("slam_env/Landmarks-v0", "landmarks"),
        ("slam_env/ActiveSLAM-v0", "active_slam"),
    ):
        path = PAGES / f"{name}.md"
        text = env_page(env_id)
        if not path.exists() or path.read_text() != text:  # no rebuild for nothing
            path.write_text(text)
        written.append(path)
    return written


def setup(app: Any) -> dict[str, Any]:
    app.connect("builder-inited", write_pages)
    return {"parallel_read_safe": True}


if __name__ == "__main__":
    for page in write_pages():
        print(page)
