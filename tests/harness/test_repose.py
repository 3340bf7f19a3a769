"""The drum's angle of repose (harness/execution/repose.py) on beds whose angle is known by construction."""
import math

import numpy as np
import pytest
import vtk
from vtk.util.numpy_support import numpy_to_vtk

from harness.execution import repose

RADIUS = 0.04      # m, the drum of testcases/scenes/drum
DIAMETER = 0.004   # m
TIMESTEP = 2e-5    # s


def segment_bed(angle_deg: float, depth: float, spacing: float = 0.001) -> np.ndarray:
    """Particle centres (m) filling the circular segment below a chord at ``depth`` under the centre, turned by
    ``angle_deg`` so that the chord rises towards -x; mirror-symmetric about the segment's symmetry line and
    with a row of centres on the chord itself (the free surface)."""
    # the segment in its own frame: chord horizontal at z = -depth, symmetric in x
    half = math.sqrt(RADIUS ** 2 - depth ** 2)
    xs = np.arange(spacing / 2, half, spacing)
    points = []
    for z in np.arange(-depth, -RADIUS, -spacing):
        for x in xs[xs ** 2 + z ** 2 < RADIUS ** 2]:
            points += [(x, z), (-x, z)]
    local = np.array(points)
    theta = math.radians(angle_deg)
    # turned right-handed about +y by -theta in the x-z plane: the +x end of the chord goes down
    x = local[:, 0] * math.cos(theta) + local[:, 1] * math.sin(theta)
    z = -local[:, 0] * math.sin(theta) + local[:, 1] * math.cos(theta)
    return np.column_stack([x, np.zeros_like(x), z])


def write_dump(path, points: np.ndarray) -> None:
    poly = vtk.vtkPolyData()
    vtk_points = vtk.vtkPoints()
    vtk_points.SetData(numpy_to_vtk(np.ascontiguousarray(points, dtype=float), deep=True))
    poly.SetPoints(vtk_points)
    writer = vtk.vtkXMLPolyDataWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(poly)
    assert writer.Write()


def bed_run(folder, angles_deg: list[float], every: int = 5000) -> None:
    """A run folder of the bundled engine: one thermo row and one dump per angle, ``every`` steps apart; ke of
    row k is k (J), rke 2k."""
    (folder / "post").mkdir()
    (folder / "log.dem").write_text("")
    rows = ["step,time,atoms,ke,rke,com_x,com_z"]
    for k, angle in enumerate(angles_deg):
        points = segment_bed(angle, depth=0.01)
        centre = points.mean(axis=0)
        step = k * every
        rows.append(f"{step},{step * TIMESTEP!r},{len(points)},{float(k)!r},{2.0 * k!r},"
                    f"{float(centre[0])!r},{float(centre[2])!r}")
        write_dump(folder / "post" / f"drum_{step}.vtp", points)
    (folder / "thermo.csv").write_text("\n".join(rows) + "\n")


def test_a_flat_bed_gives_its_angle_from_the_centre_of_mass_and_the_surface(tmp_path):
    # a segment's centroid lies on its symmetry line: both angles are the chord's, to round-off
    bed_run(tmp_path, [5.0, 10.0] + [32.0] * 9)          # rows at 0, 0.1, ... 1.0 s; steady from 1 s
    result = repose.measure(tmp_path, timestep=TIMESTEP, diameter=DIAMETER, t_steady=0.2, window=0.5)
    assert result["angle_com"] == pytest.approx(32.0, abs=1e-9)
    assert result["angle_surface"] == pytest.approx(32.0, abs=1e-9)
    assert result["rows"] == 9 and result["dumps"] == 9
    assert (tmp_path / "angle.txt").read_text() == "angle_com angle_surface\n32.000 32.000\n"
    series = np.loadtxt(tmp_path / "angle_series.csv", delimiter=",", skiprows=1)
    assert series[:, 1] == pytest.approx([5.0, 10.0] + [32.0] * 9, abs=1e-9)


def test_window_means_take_the_rows_of_each_window(tmp_path):
    bed_run(tmp_path, [20.0] * 11)                        # ke of row k (t = 0.1 k s) is k
    repose.measure(tmp_path, timestep=TIMESTEP, diameter=DIAMETER, t_steady=0.0, window=0.5)
    table = np.loadtxt(tmp_path / "drum.csv", delimiter=",", skiprows=1)
    # windows (0, 0.5] and (0.5, 1.0]: rows 1-5 and 6-10
    assert table[:, 0].tolist() == [0.25, 0.75]
    assert table[:, 1].tolist() == [3.0, 8.0]
    assert table[:, 2].tolist() == [6.0, 16.0]
    assert table[:, 5] == pytest.approx([20.0, 20.0], abs=1e-9)
    repose.measure(tmp_path, timestep=TIMESTEP, diameter=DIAMETER, t_steady=0.0, window=0.5, window_start=0.5)
    table = np.loadtxt(tmp_path / "drum.csv", delimiter=",", skiprows=1, ndmin=2)
    assert table[:, 0].tolist() == [0.75] and table[:, 1].tolist() == [8.0]


def test_the_drum_post_scripts_share_the_measurement():
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    for case in ("testcases/scenes/drum", "testcases/shapes/drum_repose"):
        text = (root / case / "angle.py").read_text()
        assert "repose.measure(" in text and "def " not in text, case
