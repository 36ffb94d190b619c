"""Shared fixtures of the Python tests (run by CTest: tests/CMakeLists.txt sets CUTSIM, the
command-line program, and PYTHONPATH to the build tree's package)."""
import copy
import os
import pathlib

import pytest

SOURCE = pathlib.Path(__file__).resolve().parents[2]

SMALL = {
    "name": "small",
    "description": "a 9 x 9 cloth held by two corners, falling under gravity",
    "mesh": {"grid": {"nx": 9, "ny": 9, "size": [1, 1], "diagonals": "alternating", "plane": "xy"}},
    "mass": {"total": 0.2},
    "gravity": [0, 0, -9.81],
    "forceFields": [
        {"type": "StretchSprings", "stiffness": 1000, "damping": 0.2},
        {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.002},
    ],
    "constraints": [{"type": "fixed", "near": [[0, 1, 0], [1, 1, 0]]}],
    "integrator": {"type": "implicit-euler", "rayleighMass": 3.0},
    "linearSolver": {"type": "cg", "iterations": 200, "tolerance": 1e-8},
    "timeStep": 0.005,
    "duration": 0.5,
    "output": {"every": 10},
}


@pytest.fixture
def small_scene():
    """A fresh copy of a small scene dict (tests change it freely)."""
    return copy.deepcopy(SMALL)


@pytest.fixture
def cutsim_program():
    path = os.environ.get("CUTSIM")
    if not path:
        pytest.skip("CUTSIM (the command-line program) is not set; run the tests through CTest")
    return path


@pytest.fixture
def source_dir():
    return SOURCE
