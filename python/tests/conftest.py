"""Shared fixtures of the Python module's tests (run by ctest as `python_tests`, which sets
PYTHONPATH to <build>/python, MENISCUS_CLI and MENISCUS_TEST_DATA)."""
import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
DATA = pathlib.Path(os.environ.get("MENISCUS_TEST_DATA", REPO / "tests" / "data"))


@pytest.fixture(scope="session")
def data():
    return DATA


@pytest.fixture(scope="session")
def cli():
    """Runs the meniscus CLI built beside the module; returns the CompletedProcess."""
    path = os.environ.get("MENISCUS_CLI")
    if not path or not os.access(path, os.X_OK):
        pytest.skip("MENISCUS_CLI is not set to the built meniscus executable (ctest sets it)")

    def run(*args, check=True):
        result = subprocess.run([path, *map(str, args)], capture_output=True, text=True)
        if check and result.returncode != 0:
            raise AssertionError(f"meniscus {' '.join(map(str, args))} failed ({result.returncode}):\n{result.stderr}")
        return result
    return run
