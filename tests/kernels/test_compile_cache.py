"""Compile cost is paid once: a second process loads every kernel from numba's cache,
and where no cache directory is writable the kernels still work (and say so once)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

# A process that steps both envs (their single and vector forms) and the filter, then
# reports what numba compiled (cache misses) and loaded (cache hits), over every kernel
# of the package.
_RUN = """
import json, warnings
import gymnasium as gym
import slam_env
from slam_env.kernels.base.compiling import KERNELS
for env_id in IDS:
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
_BOTH_IDS = 'IDS = ("slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0")\n' + _RUN


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, check=True
    )


def test_a_second_process_compiles_nothing() -> None:
    from slam_env.kernels.base.compiling import cache_directory

    _run(_BOTH_IDS)  # warms the cache, if the suite has not already
    stats = json.loads(_run(_BOTH_IDS).stdout.strip().splitlines()[-1])
    assert stats["misses"] == 0, stats
    assert stats["hits"] >= 4, stats  # the kernels the envs call came from the cache
    assert any(Path(cache_directory()).rglob("*.nbi"))  # in the hashed directory


def test_without_a_writable_cache_the_kernels_compile_and_warn_once() -> None:
    code = (
        "import numba.core.caching as c\n"
        "def refuse(self):\n"
        "    raise OSError('read-only file system')\n"
        "c._CacheLocator.ensure_cache_path = refuse\n"
        "import warnings\n"
        "with warnings.catch_warnings(record=True) as caught:\n"
        "    warnings.simplefilter('always')\n"
        # Landmarks-v0 alone: its kernels make the point in a fifth of the compile time.
        "    IDS = ('slam_env/Landmarks-v0',)\n"
        + "".join("    " + line + "\n" for line in _RUN.splitlines())
        + "print(json.dumps([str(w.message) for w in caught if 'numba' in str(w.message)]))\n"
    )
    out = _run(code).stdout.strip().splitlines()
    stats, notices = json.loads(out[-2]), json.loads(out[-1])
    assert stats["hits"] == 0 and stats["misses"] >= 4  # compiled here, nothing cached
    assert len(notices) == 1 and "NUMBA_CACHE_DIR" in notices[0]


def _compiled_files() -> set[Path]:
    """The source file of every kernel that the package and the agents define."""
    import agents.planners.search_kernel  # noqa: F401  (the planners' kernel)
    import slam_env.ekf
    import slam_env.envs.vector  # noqa: F401  (imports every kernel of the envs)
    from slam_env.kernels.base.compiling import KERNELS

    return {Path(k.py_func.__code__.co_filename).resolve() for k in KERNELS}


def test_every_compiled_function_of_slam_env_lives_in_the_hashed_tree() -> None:
    from slam_env.kernels.base.compiling import KERNEL_TREE

    files = _compiled_files()
    ours = {f for f in files if "slam_env" in f.parts}
    assert len(ours) >= 30  # the envs' and the filter's kernels were all imported
    assert all(KERNEL_TREE in f.parents for f in ours), sorted(map(str, ours))


def test_an_edit_to_any_compiled_file_changes_its_cache_directory(tmp_path) -> None:
    """numba checks a cached kernel only against its own file: an edit to a kernel it
    calls from another file must not reuse the cache, so the cache's name hashes every
    source of the kernel's tree (a stale cache once came from a compiled file that lay
    outside the hashed folder)."""
    from slam_env.kernels.base import compiling

    files = _compiled_files()
    trees = {compiling.tree_of(f) for f in files}
    for tree in trees:
        copy = tmp_path / tree.name
        shutil.copytree(tree, copy, ignore=shutil.ignore_patterns("__pycache__"))
        before = compiling.sources_hash(copy)
        assert before == compiling.sources_hash(tree)  # the copy hashes as the tree
        for source in (f for f in files if compiling.tree_of(f) == tree):
            edited = copy / source.relative_to(tree)
            text = edited.read_text()
            edited.write_text(text + "\n# an edit\n")
            assert compiling.sources_hash(copy) != before, source
            edited.write_text(text)
        assert Path(compiling.cache_directory(tree)).name == f"numba-{before}"
        shutil.rmtree(copy)


def test_every_kernel_releases_the_gil() -> None:
    """The vector env's chunks step on threads of one process: they run concurrently
    only inside compiled code that drops the GIL."""
    _compiled_files()  # imports every kernel
    from slam_env.kernels.base.compiling import KERNELS

    assert len(KERNELS) >= 30
    held = [k.py_func.__qualname__ for k in KERNELS if not k.targetoptions.get("nogil")]
    assert not held, held


_MOVED_KERNEL = """
import json, sys
sys.path.insert(0, sys.argv[1])
from moved.add_one import add_one
assert add_one(41) == 42
print(json.dumps({"misses": sum(add_one.stats.cache_misses.values()),
                  "hits": sum(add_one.stats.cache_hits.values())}))
"""


def test_the_cache_stays_valid_when_its_tree_moves(tmp_path) -> None:
    """What lets a wheel ship its compiled kernels: the cache's entries are found by
    their folder's path within the tree, so a tree compiled in the build directory and
    installed elsewhere loads them instead of compiling again."""
    first, second = tmp_path / "build", tmp_path / "site-packages"
    (first / "moved").mkdir(parents=True)
    (first / "moved" / "__init__.py").write_text("")
    (first / "moved" / "add_one.py").write_text(
        "from slam_env.kernels.base.compiling import kernel\n\n\n"
        "@kernel\ndef add_one(x):\n    return x + 1\n"
    )

    def run(root: Path) -> dict:
        done = _run(_MOVED_KERNEL.replace("sys.argv[1]", repr(str(root))))
        return json.loads(done.stdout.strip().splitlines()[-1])

    assert run(first) == {"misses": 1, "hits": 0}
    shutil.move(first, second)
    assert run(second) == {"misses": 0, "hits": 1}


def test_cache_entries_are_named_by_their_folder_within_the_tree() -> None:
    from slam_env.kernels.base.compiling import KERNEL_TREE, TreeCacheLocator

    subpath = TreeCacheLocator.get_suitable_cache_subpath
    assert subpath(str(KERNEL_TREE / "ekf" / "filter.py")) == "ekf"
    assert subpath(str(KERNEL_TREE / "base" / "models.py")) == "base"
    assert subpath(str(KERNEL_TREE / "__init__.py")) == "tree"
