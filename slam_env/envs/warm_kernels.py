"""Compile the kernels that the default envs and the filter run, into the package's own
numba cache: ``python -m slam_env.envs.warm_kernels``.

A wheel's build runs it on the built tree (``setup.py``), so that a user who did
``pip install`` and nothing else finds the default configuration's kernels compiled
(for the CPU the wheel was built on: numba recompiles, and caches, where the CPU
differs). Other options compile their own kernels on first use, as before.
"""

from __future__ import annotations

import contextlib

import gymnasium as gym
import numpy as np

from slam_env.ekf import EKFSLAM
from slam_env.extras import MissingExtra
from slam_env.kernels.base.compiling import cache_directory, kernel_counts

IDS = ("slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0")


def warm() -> dict[str, int]:
    """Run both IDs (single, native vector and a frame) and the filter; the
    kernels and specialisations compiled (or found in the cache)."""
    for env_id in IDS:
        env = gym.make(env_id)
        env.action_space.seed(0)
        env.reset(seed=0)
        for _ in range(3):
            env.step(env.action_space.sample())
        env.close()
        envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
        envs.action_space.seed(0)
        envs.reset(seed=0)
        for _ in range(3):
            envs.step(envs.action_space.sample())
        envs.close()
        drawn = gym.make(env_id, render_mode="rgb_array")
        drawn.reset(seed=0)
        # The visible region's ray casts run before the pictures need the 'render' extra.
        with contextlib.suppress(MissingExtra):
            drawn.render()
        drawn.close()
    f = EKFSLAM(
        alphas=(0.01, 0.01, 0.01, 0.01), measurement_cov=np.diag([0.01, 0.001]), max_landmarks=3
    )
    f.predict((0.1, 0.5, 0.0))
    f.update(np.array([[2.0, 0.3], [3.0, -0.2]]), np.array([0, 2]))
    return kernel_counts()


def main() -> None:
    import slam_env

    print(f"slam_env: compiling the default kernels of {slam_env.__file__}")
    counts = warm()
    print(
        f"slam_env kernels: {counts['specialisations']} specialisations of {counts['kernels']} "
        f"kernels ({counts['compiled']} compiled now) in {cache_directory()}"
    )


if __name__ == "__main__":
    main()
