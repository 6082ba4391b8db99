"""Shared pieces of the Python module's tests (run by ctest, label "python": PYTHONPATH is the
build tree's python/ folder, DROPS_BINARY the drops program, DROPS_SOURCE_DIR the sources)."""

import os
import pathlib
import subprocess

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("DROPS_SOURCE_DIR",
                                         pathlib.Path(__file__).resolve().parents[2]))
DROPS_BINARY = os.environ.get("DROPS_BINARY", str(SOURCE_DIR / "build" / "drops"))
GP_MI_CONFIG = SOURCE_DIR / "configs" / "pendubot-gp_mi.yaml"
# A few episodes with a small optimizer budget: a run of about a second.
TINY = ["episodes=3", "optimizer.max_evaluations=40", "optimizer.prior_optimizations=1"]


def run_cli(*args, cwd=None):
    """Runs the drops program; returns the CompletedProcess (text, stdout and stderr captured)."""
    return subprocess.run([DROPS_BINARY, *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


@pytest.fixture(scope="session")
def drops_program():
    if not os.path.exists(DROPS_BINARY):
        pytest.fail(f"the drops program is not at {DROPS_BINARY} (set DROPS_BINARY)")
    return DROPS_BINARY
