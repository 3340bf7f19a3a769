"""An STL box (12 triangles, faces exactly on the planes) against the same box of six plane walls.

testcases/scenes/stl_box: 11 spheres thrown at the faces, the diagonals that split them into triangles, the
edges and a corner, Hertz + tangential history, gravity, 0.3 s. Sphere-triangle contact must reduce to the
plane's contact on a face (once, also on a diagonal shared by two triangles, with no extra edge contact), so
the trajectories agree to round-off. This is the firm check; the test case's `mesh` run (compare_box.py) is
its harness form.
"""
from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest

from conftest import REPO, read_csv

CASE = REPO / "testcases" / "scenes" / "stl_box"
HALF_WIDTH = 0.03125      # m, A: the box is x, y in [-A, A], z in [0, 2 A]
BOX = 2 * HALF_WIDTH      # m, its height


def run_scene(folder, name: str) -> dict:
    """Run the test case's scene `name` (box_planes / box_mesh) in a copy of the test case; its trajectory."""
    from engine.__main__ import run as run_engine

    shutil.copytree(CASE, folder)
    (folder / "post").mkdir(exist_ok=True)
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        code = run_engine(f"{name}.json", "log.dem", {}, echo=False)
    finally:
        os.chdir(cwd)
    assert code == 0, (folder / "log.dem").read_text()[-2000:]
    return read_csv(folder / "post" / f"trajectory_{name.split('_')[1]}.csv")


@pytest.fixture(scope="module")
def trajectories(tmp_path_factory):
    root = tmp_path_factory.mktemp("stl_box")
    return run_scene(root / "planes", "box_planes"), run_scene(root / "mesh", "box_mesh")


def test_stl_box_follows_the_plane_box(trajectories):
    planes, mesh = trajectories
    assert list(planes) == list(mesh)
    np.testing.assert_array_equal(planes["step"], mesh["step"])
    assert len(planes["step"]) == 301
    columns = [c for c in planes if c not in ("step", "time")]
    assert len(columns) == 33
    worst = max(float(np.max(np.abs(planes[c] - mesh[c]))) for c in columns)
    assert worst <= 1e-12 * BOX, f"largest position difference {worst:.3g} m"


def test_the_spheres_touch_two_walls_at_once(trajectories):
    """The scene does what it claims: on the plane box some sphere touches two walls (an edge) at a printed row
    (a three-wall corner contact lasts less than the 1 ms between rows, so it is not asserted here)."""
    planes, _ = trajectories
    scene = json.loads((CASE / "box_planes.json").read_text())
    radii = [c["radius"] for c in scene if c.get("object") == "particle"]
    a = HALF_WIDTH
    most = 0
    for i, r in enumerate(radii, start=1):
        x, y, z = planes[f"x[{i}]"], planes[f"y[{i}]"], planes[f"z[{i}]"]
        gaps = np.stack([x + a, a - x, y + a, a - y, z, 2 * a - z], axis=1) - r
        most = max(most, int((gaps < 0).sum(axis=1).max()))
    assert most >= 2
