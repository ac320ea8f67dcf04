"""What the core install (``pip install slam_env``, no extras) runs, checked in a venv
that holds nothing else (``make test-core``, which CI runs): both IDs step, the native
vector env steps, the filter runs, Gymnasium's env checker passes on both IDs, what
needs an extra says which in one line, and none of it compiles a kernel: the wheel's
build compiled them into the package (``setup.py``). Run as a script, so that
``slam_env`` comes from the installed package, not from the source tree."""

from __future__ import annotations

import importlib.util
import warnings

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env

import slam_env
from slam_env.ekf import EKFSLAM
from slam_env.extras import EXTRAS, MissingExtra
from slam_env.kernels.base.compiling import KERNELS

IDS = ("slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0")


def main() -> None:
    assert "site-packages" in slam_env.__file__, f"not the installed package: {slam_env.__file__}"
    for extra in ("render", "agents"):
        present = [m for m in EXTRAS[extra] if importlib.util.find_spec(m) is not None]
        assert not present, f"the core install holds {present} of the {extra!r} extra"

    for env_id in IDS:
        env = gym.make(env_id)
        env.action_space.seed(0)
        obs, _ = env.reset(seed=0)
        for _ in range(50):
            obs, reward, *_ = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs) and isinstance(reward, float)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # the checker's warnings fail the check
            check_env(env.unwrapped, skip_render_check=True)
        venv = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point")
        venv.action_space.seed(0)
        venv.reset(seed=0)
        for _ in range(20):
            _, rewards, *_ = venv.step(venv.action_space.sample())
        assert rewards.shape == (3,)
        venv.close()
        drawn = gym.make(env_id, render_mode="rgb_array")
        drawn.reset(seed=0)
        try:
            drawn.render()
        except MissingExtra as exc:
            assert "slam_env[render]" in str(exc) and "\n" not in str(exc), exc
        else:
            raise AssertionError("rendering without the render extra did not say so")

    f = EKFSLAM(
        alphas=(0.01, 0.01, 0.01, 0.01), measurement_cov=np.diag([0.01, 0.001]), max_landmarks=3
    )
    f.predict((0.1, 0.5, 0.0))
    f.update(np.array([[2.0, 0.3], [3.0, -0.2]]), np.array([0, 2]))
    assert f.mean.shape == (7,) and f.state_to_id.tolist() == [0, 2]
    compiled = {k.py_func.__qualname__ for k in KERNELS if sum(k.stats.cache_misses.values())}
    assert not compiled, f"a fresh install compiled {sorted(compiled)}"
    loaded = sum(sum(k.stats.cache_hits.values()) for k in KERNELS)
    assert loaded >= 4, f"only {loaded} kernels came from the shipped cache"
    print(
        f"core install: both IDs, the native vector env and the filter run ({slam_env.__version__})"
    )


if __name__ == "__main__":
    main()
