"""Shared set-up of the module's tests: where the source tree and the mca command are.

ctest (python/CMakeLists.txt) sets MCA_SOURCE_DIR, MCA_BINARY and PYTHONPATH (this build's module);
run by hand, the defaults are this checkout and its release build.
"""
import os
import pathlib
import subprocess

import pytest

# The CPU backend where a scene or Simulation leaves the backend on auto (which takes an NVIDIA GPU where
# there is one): these are the CPU's checks; MCA_BACKEND set by hand runs them elsewhere.
os.environ.setdefault("MCA_BACKEND", "cpu")

SOURCE_DIR = pathlib.Path(os.environ.get("MCA_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
MCA_BINARY = pathlib.Path(os.environ.get("MCA_BINARY", SOURCE_DIR / "build" / "release" / "mca"))


@pytest.fixture(scope="session")
def source_dir():
    return SOURCE_DIR


@pytest.fixture(scope="session")
def mca_binary():
    if not MCA_BINARY.exists():
        pytest.fail(f"{MCA_BINARY} is missing: build with cmake --build --preset release (or set MCA_BINARY)")
    return MCA_BINARY


def run_command(binary, *args, cwd=None):
    """Runs the mca command; fails the test with its stderr when it fails."""
    r = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True, cwd=cwd)
    if r.returncode != 0:
        pytest.fail(f"mca {' '.join(map(str, args))} exited with {r.returncode}:\n{r.stderr}")
    return r
