"""Regenerate the README's pictures in ``docs/``, small enough to commit.

    .venv/bin/python docs/make_pictures.py [--out docs]

* ``demo.gif``: the demo's movie (``slam-env demo``: its default agent, seed 0, the
  default world) in an episode of 200 steps, every 8th step (a ``lookahead`` agent
  looks ahead to its episode's end, so this is not the first 200 steps of the next);
* ``final_map.png``: the demo's final map, after the whole 500-step episode;
* ``consistency.png``: the pose NEES in its χ² band and the map RMSE over time of
  ``slam-env evaluate --agents random,frontier,ppo --episodes 10 --seed 0``.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

from agents.evaluation.compare import evaluate
from agents.evaluation.demo import demo

GIF_STEPS = 200
GIF_FRAMES = 26  # every 8th step: a picture that stays well under 300 KB


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    args = parser.parse_args(argv)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        short = demo(
            None,  # the demo's own agent
            seed=0,
            out_dir=Path(tmp) / "short",
            max_steps=GIF_STEPS,
            gif_max_frames=GIF_FRAMES,
            verbose=False,
        )
        shutil.copy(short.files["gif"], out / "demo.gif")
        full = demo(None, seed=0, out_dir=Path(tmp) / "full", gif=False, verbose=False)
        shutil.copy(full.files["map_png"], out / "final_map.png")
        result = evaluate(
            ["random", "frontier", "ppo"],
            episodes=10,
            seed=0,
            out_dir=Path(tmp) / "eval",
            progress=False,
            verbose=False,
        )
        shutil.copy(result.files["consistency_png"], out / "consistency.png")
        for row in result.summary:
            print(f"{row['agent']}: nees_in_band {row['nees_in_band']:.3f}")
    for name in ("demo.gif", "final_map.png", "consistency.png"):
        print(f"{out / name}: {(out / name).stat().st_size / 1024:.0f} KB")


if __name__ == "__main__":
    main()
