"""The wheel's build compiles the default configuration's kernels into the package's
numba cache (``slam_env.envs.warm_kernels``), so that the first step of a fresh install
loads them instead of compiling them. Everything else is in ``pyproject.toml``.
``SLAM_ENV_BUILD_KERNELS=0`` builds without them."""

import os
import subprocess
import sys

from setuptools import setup
from setuptools.command.build_py import build_py


class BuildWithKernels(build_py):
    def run(self) -> None:
        super().run()
        if self.editable_mode or os.environ.get("SLAM_ENV_BUILD_KERNELS", "1") == "0":
            return  # an editable install compiles into its source tree on first use
        built = os.path.abspath(self.build_lib)
        # The built tree first; pip's build environment (on PYTHONPATH) after it.
        path = os.pathsep.join(p for p in (built, os.environ.get("PYTHONPATH")) if p)
        env = dict(os.environ, PYTHONPATH=path)
        env.pop("NUMBA_CACHE_DIR", None)  # into the package's own cache
        module = [sys.executable, "-m", "slam_env.envs.warm_kernels"]
        subprocess.run(module, check=True, env=env, cwd=built)


setup(cmdclass={"build_py": BuildWithKernels})
