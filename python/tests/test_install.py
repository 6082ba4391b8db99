"""The package installed with `cmake --install` into a prefix imports from there (the extension
finds the prefix's drops libraries through its RPATH) and runs the same schema."""

import os
import pathlib
import subprocess
import sys

import pytest

import drops


def test_the_installed_package_imports_from_its_prefix(tmp_path):
    build = os.environ.get("DROPS_BUILD_DIR")
    cmake = os.environ.get("DROPS_CMAKE", "cmake")
    site = os.environ.get("DROPS_PYTHON_INSTALL_DIR")
    if not build or not site:
        pytest.skip("run by ctest (DROPS_BUILD_DIR, DROPS_PYTHON_INSTALL_DIR)")
    if os.path.isabs(site):
        pytest.skip(f"DROPS_PYTHON_INSTALL_DIR is the absolute {site}, outside any prefix")
    prefix = tmp_path / "prefix"
    installed = subprocess.run([cmake, "--install", build, "--prefix", prefix],
                               capture_output=True, text=True, timeout=300)
    assert installed.returncode == 0, installed.stderr
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(prefix / site)
    probe = subprocess.run(
        [sys.executable, "-c",
         "import drops; print(drops.__file__); print(len(drops.schema()))"],
        capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)
    assert probe.returncode == 0, probe.stderr
    where, keys = probe.stdout.split()
    assert pathlib.Path(where).resolve().is_relative_to(prefix.resolve())
    assert int(keys) == len(drops.schema())
