"""The LIGGGHTS adapter on logs and dumps of real LIGGGHTS runs, checked against analytic values."""
from __future__ import annotations

import math

import numpy as np
import pytest
import vtk
from vtk.util.numpy_support import vtk_to_numpy

from harness.adapters.liggghts import LiggghtsAdapter

from liggghts_support import N_FREE_FALL, copy_scene, needs_liggghts, needs_mpirun, run_liggghts

G = 9.81  # m/s^2
DT = 1e-5  # s
SPHERE_MASS = 2500 * 4 / 3 * math.pi * 0.0015 ** 3  # kg, radius 1.5 mm, density 2500 kg/m^3

adapter = LiggghtsAdapter()
pytestmark = [needs_liggghts, pytest.mark.liggghts]


def read_legacy_vtk(path):
    reader = vtk.vtkPolyDataReader()
    reader.SetFileName(str(path))
    reader.ReadAllFieldsOn()
    reader.ReadAllScalarsOn()
    reader.ReadAllVectorsOn()
    reader.Update()
    return reader.GetOutput()


def test_thermo_of_two_run_blocks_is_free_fall(free_fall_run):
    thermo = adapter.read_thermo(free_fall_run)
    # 0..500 and 500..1000 every 100 steps; step 500 printed by both blocks is kept once
    assert list(thermo["step"]) == list(range(0, 1001, 100))
    assert (thermo["atoms"] == N_FREE_FALL).all()
    # Velocity-Verlet is exact under constant gravity: ke = 1/2 M (g t)^2
    expected = 0.5 * N_FREE_FALL * SPHERE_MASS * (G * thermo["step"] * DT) ** 2
    np.testing.assert_allclose(thermo["ke"], expected, rtol=1e-6, atol=1e-15)
    # rke comes from "compute spin all erotate/sphere" (header "spin"); nothing spins in free fall
    assert (thermo["rke"] == 0).all()
    # a column of the second block only (thermo_style changed) is kept, NaN in the first block; the
    # repeated step 500 keeps the first block's row
    assert thermo["CPU"].isna().sum() == 6 and thermo["CPU"].notna().sum() == 5


def test_timing_sums_every_loop_block(free_fall_run):
    timing = adapter.read_timing(free_fall_run)
    log = (free_fall_run / adapter.log_file()).read_text()
    loops = [float(line.split()[3]) for line in log.splitlines() if line.startswith("Loop time of")]
    assert len(loops) == 2
    assert timing["total"] == pytest.approx(sum(loops))
    sections = sum(timing[k] for k in ("pair", "neigh", "comm", "modify", "output", "other"))
    # LIGGGHTS' sections are a breakdown of the loop time (their percentages add up to 100)
    assert sections == pytest.approx(timing["total"], rel=0.02, abs=1e-5)
    assert timing["pair"] > 0 and timing["other"] > 0


def test_warnings_counted_errors_none(free_fall_run):
    scan = adapter.scan_log(free_fall_run)
    assert scan.errors == []
    # check/timestep/gran warns every 100 steps about the Rayleigh time (dt is ~5 % of it)
    rayleigh = [w for w in scan.warnings if "rayleigh time" in w]
    assert len(rayleigh) == 10
    assert all(w.startswith("WARNING") for w in scan.warnings)


def test_legacy_vtk_dumps_read_with_vtk(free_fall_run):
    files = adapter.vtk_files(free_fall_run)
    # dump every 250 steps over 1000 steps; LIGGGHTS' fall_boundingBox_*.vtk files are not particle dumps
    assert [f.name for f in files] == [f"fall_{s}.vtk" for s in (0, 250, 500, 750, 1000)]
    last = read_legacy_vtk(files[-1])
    assert last.GetNumberOfPoints() == N_FREE_FALL
    data = last.GetPointData()
    radius = vtk_to_numpy(data.GetArray("radius"))
    np.testing.assert_allclose(radius, 0.0015)
    velocity = vtk_to_numpy(data.GetArray("v"))
    np.testing.assert_allclose(velocity[:, 2], -G * 1000 * DT, rtol=1e-9)
    z = vtk_to_numpy(last.GetPoints().GetData())[:, 2]
    first_z = vtk_to_numpy(read_legacy_vtk(files[0]).GetPoints().GetData())[:, 2]
    np.testing.assert_allclose(np.sort(first_z - z), 0.5 * G * (1000 * DT) ** 2, rtol=1e-4)


def test_error_line_fails_and_is_reported(tmp_path):
    (tmp_path / "in.bad").write_text("units si\natom_style granular\nfrobnicate all\n")
    result = run_liggghts(tmp_path, "in.bad")
    scan = adapter.scan_log(tmp_path)
    assert len(scan.errors) == 1 and "Unknown command: frobnicate all" in scan.errors[0]
    assert result.returncode != 0


def test_wall_impact_restitution(tmp_path):
    """Hertz particle-wall impact: rebound/impact speed equals the input restitution e (LIGGGHTS' damping)."""
    folder = copy_scene("wall_impact", tmp_path)
    for e in (0.5, 0.9):
        run_liggghts(folder, "in.impact", {"e": e})
        thermo = adapter.read_thermo(folder)
        ke_in, ke_out = thermo["ke"].iloc[0], thermo["ke"].iloc[-1]
        assert math.sqrt(ke_out / ke_in) == pytest.approx(e, rel=0.01)
        # head-on impact: friction cannot spin the sphere
        assert (thermo["rke"] == 0).all()


@needs_mpirun
def test_mpi_run_matches_serial(tmp_path, free_fall_run):
    (tmp_path / "in.free_fall").write_text((free_fall_run / "in.free_fall").read_text())
    result = run_liggghts(tmp_path, "in.free_fall", nprocs=2)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "on 2 procs" in (tmp_path / adapter.log_file()).read_text()
    parallel, serial = adapter.read_thermo(tmp_path), adapter.read_thermo(free_fall_run)
    np.testing.assert_allclose(parallel["ke"], serial["ke"], rtol=1e-7)
    assert adapter.read_timing(tmp_path)["total"] > 0
