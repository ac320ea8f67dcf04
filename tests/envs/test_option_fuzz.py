"""Every numeric option of both env IDs, fuzzed with absurd but typeable values: each
example is refused naming the option, or runs inside its spaces with finite rewards and
no NaN in info, within 2 s of CPU time and under an address-space limit (see
tests/envs/option_fuzz.py, which runs in its own process so that the limit cannot hurt the
test session)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("env_id", ["slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0"])
def test_every_numeric_option_is_refused_by_name_or_runs_cleanly(env_id):
    done = subprocess.run(
        [sys.executable, "-m", "tests.envs.option_fuzz", env_id],
        cwd=ROOT,
        env={**os.environ, "SDL_VIDEODRIVER": "dummy"},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-4000:]
    assert "0 option(s) failed" in done.stdout
