"""Compile cost is paid once: a second process loads every kernel from numba's cache,
and where no cache directory is writable the kernels still work (and say so once)."""

from __future__ import annotations

import json
import subprocess
import sys

# A process that steps both envs and the filter, then reports what numba compiled
# (cache misses) and loaded (cache hits), over every kernel of the package.
_RUN = """
import json, warnings
import gymnasium as gym
import slam_env
from slam_env.kernels import KERNELS
for env_id in ("slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0"):
    env = gym.make(env_id)
    env.reset(seed=0)
    for _ in range(5):
        env.step(env.action_space.sample())
    venv = gym.make_vec(env_id, num_envs=2)
    venv.reset(seed=0)
    venv.step(venv.action_space.sample())
misses = sum(sum(k.stats.cache_misses.values()) for k in KERNELS)
hits = sum(sum(k.stats.cache_hits.values()) for k in KERNELS)
print(json.dumps({"misses": misses, "hits": hits}))
"""


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, check=True
    )


def test_a_second_process_compiles_nothing() -> None:
    from pathlib import Path

    import slam_env.kernels as kernels

    _run(_RUN)  # warms the cache, if the suite has not already
    stats = json.loads(_run(_RUN).stdout.strip().splitlines()[-1])
    assert stats["misses"] == 0, stats
    assert stats["hits"] >= 4, stats  # the kernels the envs call came from the cache
    assert any(Path(kernels.cache_directory()).rglob("*.nbi"))  # in the hashed directory


def test_without_a_writable_cache_the_kernels_compile_and_warn_once() -> None:
    code = (
        "import numba.core.caching as c\n"
        "def refuse(self):\n"
        "    raise OSError('read-only file system')\n"
        "c._CacheLocator.ensure_cache_path = refuse\n"
        "import warnings\n"
        "with warnings.catch_warnings(record=True) as caught:\n"
        "    warnings.simplefilter('always')\n"
        + "".join("    " + line + "\n" for line in _RUN.splitlines())
        + "print(json.dumps([str(w.message) for w in caught if 'numba' in str(w.message)]))\n"
    )
    out = _run(code).stdout.strip().splitlines()
    stats, notices = json.loads(out[-2]), json.loads(out[-1])
    assert stats["hits"] == 0 and stats["misses"] >= 4  # compiled here, nothing cached
    assert len(notices) == 1 and "NUMBA_CACHE_DIR" in notices[0]


def test_the_cache_is_named_by_every_kernel_source(tmp_path) -> None:
    """numba checks a cached kernel only against its own file: an edit to a kernel it
    calls from another file must not reuse the cache, so its name hashes them all."""
    import shutil
    from pathlib import Path

    import slam_env.kernels as kernels

    folder = tmp_path / "kernels"
    shutil.copytree(Path(kernels.__file__).parent, folder, ignore=shutil.ignore_patterns("__*"))
    before = kernels.sources_hash(folder)
    assert before == kernels.sources_hash(folder)  # stable
    models = folder / "models.py"
    models.write_text(models.read_text() + "\n# an edit\n")
    assert kernels.sources_hash(folder) != before
    here = kernels.sources_hash(Path(kernels.__file__).parent)
    assert Path(kernels.cache_directory()).name == f"numba-{here}"
