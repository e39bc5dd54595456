"""Shared fixtures: the shared data folder (skip with a reason when absent), small geometry."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from exactgrasp.datapath import data_dir

os.environ.setdefault("EXACTGRASP_NO_PROGRESS", "1")
# The disk caches of one test run start empty and stay out of the user's cache folder (set
# here, before any test, so that worker processes inherit it). Once per process: test modules
# that import this file as `tests.conftest` run it a second time.
if os.environ.get("EXACTGRASP_TEST_CACHE_PROCESS") != str(os.getpid()):
    os.environ["EXACTGRASP_CACHE"] = tempfile.mkdtemp(prefix="exactgrasp-test-cache-")
    os.environ["EXACTGRASP_TEST_CACHE_PROCESS"] = str(os.getpid())
TEST_CACHE = os.environ["EXACTGRASP_CACHE"]


def pytest_sessionfinish():
    """Remove the run's disk caches (the worker processes that used them are gone by now)."""
    shutil.rmtree(TEST_CACHE, ignore_errors=True)


@pytest.fixture(autouse=True)
def _mesh_warnings_heard_afresh():
    """Each test hears the mesh warnings (`exactgrasp.errors.warn_once`) as a new process
    would: what earlier tests were told is forgotten."""
    from exactgrasp.errors import WARNED

    WARNED.clear()


#: ``$EXACTGRASP_DATA``, else ``../shared/data`` beside the repository (`data_dir`).
SHARED_DATA = data_dir()


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not (SHARED_DATA / "osu-objects").is_dir():
        pytest.skip(
            f"shared data not found at {SHARED_DATA} (the authors' objects and grasps; "
            "set EXACTGRASP_DATA to its folder)"
        )
    return SHARED_DATA


def box_arrays(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """A closed, outward-oriented axis-aligned box as (vertices (8, 3), faces (12, 3))."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    vertices = lo + corners * (hi - lo)
    faces = np.array(
        [
            [0, 1, 3],
            [0, 3, 2],  # x = lo
            [4, 6, 7],
            [4, 7, 5],  # x = hi
            [0, 4, 5],
            [0, 5, 1],  # y = lo
            [2, 3, 7],
            [2, 7, 6],  # y = hi
            [0, 2, 6],
            [0, 6, 4],  # z = lo
            [1, 5, 7],
            [1, 7, 3],  # z = hi
        ]
    )
    return vertices, faces


def box_grasp():
    """A small box object in a one-box hand (palm frame at its top face): a grasp every
    backend computes in milliseconds."""
    import exactgrasp as eg

    hand = eg.Hand.from_meshes(
        [box_arrays([-0.05, -0.05, 0.0], [0.05, 0.05, 0.02])],
        frame=eg.HandFrame.from_palm([0, 0, 0.02], [0, 0, 1], [0, 1, 0], 0.08),
    )
    return eg.Grasp(hand, eg.Solid(*box_arrays([0, 0, 0], [0.01, 0.01, 0.01])), name="g")
