"""Shared fixtures: small procedural scenes and cell grids (the tests must stay quick)."""

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import sightline as sl

# A small city: a few thousand triangles, baked in milliseconds per cell.
CITY = "procedural:city?seed=3&size=3000"
REPO = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="session")
def city():
    return sl.load(CITY)


@pytest.fixture(scope="session")
def city_cells(city):
    lo, hi = city.bounds
    return sl.grid(lo, hi, (3, 2, 1))


@pytest.fixture
def two_boxes():
    """Vertices and triangles of two unit cubes side by side (24 triangles)."""
    corners = np.array(
        [[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=np.float32
    )
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = []
    for a, b, c, d in quads:
        tris += [(a, b, c), (a, c, d)]
    tris = np.array(tris, dtype=np.uint32)
    vertices = np.concatenate([corners, corners + np.float32([3, 0, 0])])
    triangles = np.concatenate([tris, tris + 8])
    return vertices, triangles


@pytest.fixture(scope="session")
def cli():
    """The sightline CLI: $SIGHTLINE_BIN, else a binary cargo built in target/."""
    path = os.environ.get("SIGHTLINE_BIN")
    if not path:
        candidates = [REPO / "target" / p / "sightline" for p in ("debug", "release")]
        found = [c for c in candidates if c.exists()]
        path = str(found[0]) if found else shutil.which("sightline")
    assert path, "build the CLI first (cargo build -p sightline-cli) or set SIGHTLINE_BIN"
    return path
