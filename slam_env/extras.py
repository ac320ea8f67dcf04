"""The optional extras of the package, and the one-line error where one is missing.

The core install (``pip install slam_env``) runs both IDs, the native vector env, the
filter and the env checkers; pictures and agents come with extras. Code that needs an
extra calls :func:`require` before it imports from it, so that a missing extra is one
:class:`MissingExtra` that names it, not a traceback from deep inside an import.
"""

from __future__ import annotations

import importlib.util

__all__ = ["EXTRAS", "MissingExtra", "require"]

# extra -> the modules it installs (the distribution's optional dependencies).
EXTRAS: dict[str, tuple[str, ...]] = {
    "render": ("pygame", "matplotlib", "imageio"),
    "agents": ("stable_baselines3", "torch", "tensorboard", "tqdm", "rich"),
    "recurrent": ("sb3_contrib",),
    "rllib": ("ray",),
    "gtsam": ("gtsam",),  # the smoothing belief, slam_env.smoothing
}


class MissingExtra(ImportError):
    """What needs an extra was asked for where that extra is not installed."""


def require(extra: str, what: str) -> None:
    """``MissingExtra`` (one line naming the extra and the command that installs it)
    unless every module of ``extra`` can be imported; ``what`` is the thing that needs
    it. Nothing is imported."""
    missing = [m for m in EXTRAS[extra] if importlib.util.find_spec(m) is None]
    if missing:
        raise MissingExtra(
            f"{what} needs the {extra!r} extra ({', '.join(missing)} not installed): "
            f"pip install 'slam_env[{extra}]'"
        )
