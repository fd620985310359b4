"""Shared fixtures of the Python module's tests: the organsim program next to
the module (for comparing the two), the shipped samples, and one quick bake of
the shipped phantom that every test can use."""
import os
import pathlib
import subprocess

import pytest

import organsim

SAMPLES = pathlib.Path(os.environ.get("ORGANSIM_DATA_SAMPLES", pathlib.Path(__file__).parents[2] / "data_samples"))
PROGRAM = os.environ.get("ORGANSIM_EXECUTABLE", "organsim")

# The same small bake as the C++ command tests (a few seconds).
QUICK_BAKE = dict(seed=(-65, 5, 0), surface_vertices=800, tet_size=12, stations=8, section_samples=32)


def run_program(*arguments):
    """The organsim program: (exit code, stdout, stderr)."""
    done = subprocess.run([PROGRAM, *map(str, arguments)], capture_output=True, text=True)
    return done.returncode, done.stdout, done.stderr


@pytest.fixture(scope="session")
def phantom(tmp_path_factory):
    """(path, report) of the shipped phantom baked through organsim.bake."""
    path = tmp_path_factory.mktemp("phantom") / "phantom.organ"
    report = organsim.bake(SAMPLES / "phantom_ct.nii.gz", path, **QUICK_BAKE)
    return path, report
