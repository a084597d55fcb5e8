"""Shared fixtures: the generated frames and the C++ run of them (ss_python_fixture), written
once per session into a temporary folder. ctest sets SS_PYTHON_FIXTURE, SS_MODEL, SS_TEST_DATA
and PYTHONPATH (python/CMakeLists.txt)."""
import os
import pathlib
import subprocess
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))  # results.py

from results import Frames  # noqa: E402


def _env(name):
    value = os.environ.get(name)
    if not value:
        pytest.fail(f"{name} is not set; run the tests through ctest (python_module)")
    return value


@pytest.fixture(scope="session")
def model_path():
    return _env("SS_MODEL")


@pytest.fixture(scope="session")
def test_data():
    return pathlib.Path(_env("SS_TEST_DATA"))


@pytest.fixture(scope="session")
def sequence(tmp_path_factory, model_path):
    """The touch sequence's frames, and the folder with the C++ results of it."""
    folder = tmp_path_factory.mktemp("sequence")
    subprocess.run([_env("SS_PYTHON_FIXTURE"), "sequence", str(folder), model_path], check=True)
    frames = Frames(folder)
    frames.folder = folder
    return frames
