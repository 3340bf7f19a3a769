"""The LAMMPS adapter against real logs of Debian's lmp: thermo of several run blocks, the timing table,
warnings, errors, MPI runs and custom dumps read as VTK."""
from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from lammps_support import (
    FREE_FALL,
    MASS,
    N_FREE_FALL,
    needs_lammps,
    needs_mpirun,
    run_lammps,
)

from harness.adapters import get_adapter
from harness.adapters.base import UserError
from harness.adapters.lammps import LammpsAdapter, parse_timing, read_custom_dump
from harness.execution.postprocess import read_vtk_points, vtk_aggregates

pytestmark = [needs_lammps, pytest.mark.lammps]


def free_fall_ke(step: int) -> float:
    """Exact kinetic energy (J) of the free fall: 1/2 N m (|v0|^2 + (g t)^2), v0 = (0.3, 0.1, 0) m/s."""
    t = step * 1e-5
    return 0.5 * N_FREE_FALL * MASS * (0.3 ** 2 + 0.1 ** 2 + (9.81 * t) ** 2)


def test_lookup_and_scripts():
    adapter = get_adapter("lammps")
    assert isinstance(adapter, LammpsAdapter) and adapter.log_file() == "log.lammps"
    assert adapter.accepts_script("in.pour") and adapter.accepts_script("scene.lmp")
    assert not adapter.accepts_script("scene.json") and not adapter.accepts_script("scene.py")
    assert adapter.command(["/usr/bin/lmp"], "in.x", {"n": 3}, "log.lammps") == [
        "/usr/bin/lmp", "-in", "in.x", "-var", "n", "3", "-log", "log.lammps"]


def test_thermo_of_two_run_blocks(free_fall_run):
    """Both blocks, step 500 once, the rke column from the echoed erotate/sphere compute, CPU (second block
    only) left out; ke equals the exact free fall to the 8 digits LAMMPS prints."""
    thermo = LammpsAdapter().read_thermo(free_fall_run)
    assert list(thermo["step"]) == list(range(0, 1001, 100))
    assert list(thermo.columns[:4]) == ["step", "atoms", "ke", "rke"]
    assert "CPU" not in thermo.columns and "c_spin" not in thermo.columns
    assert (thermo["atoms"] == N_FREE_FALL).all() and (thermo["rke"] == 0).all()
    for step, ke in zip(thermo["step"], thermo["ke"]):
        assert ke == pytest.approx(free_fall_ke(step), rel=1e-7)


def test_thermo_columns_mapping(free_fall_run):
    adapter = LammpsAdapter()
    thermo = adapter.read_thermo(free_fall_run, {"rke": "c_spin", "ke": "KinEng"})
    assert thermo["ke"].iloc[-1] == pytest.approx(free_fall_ke(1000), rel=1e-7)
    with pytest.raises(UserError, match=r"log\.lammps: thermo_columns\.rke = 'c_nothing' is not a thermo column"):
        adapter.read_thermo(free_fall_run, {"rke": "c_nothing"})


def test_timing_sums_the_blocks(free_fall_run):
    """total = the sum of both 'Loop time' values; the sections of LAMMPS' table (avg column) add up to it."""
    text = (free_fall_run / "log.lammps").read_text()
    loops = [float(v) for v in re.findall(r"^Loop time of (\S+) on 1 procs for 500 steps", text, re.M)]
    assert len(loops) == 2
    timing = LammpsAdapter().read_timing(free_fall_run)
    assert timing["total"] == pytest.approx(sum(loops), rel=1e-12)
    sections = sum(timing[k] for k in ("pair", "neigh", "comm", "modify", "output", "other"))
    assert sections == pytest.approx(timing["total"], rel=0.05, abs=2e-5)
    assert timing["output"] > 0 and timing["modify"] > 0


def test_timing_table_of_a_crafted_log():
    lines = ["Loop time of 2.5 on 4 procs for 100 steps with 10 atoms", "",
             "Section |  min time  |  avg time  |  max time  |%varavg| %total",
             "---------------------------------------------------------------",
             "Pair    | 0.9        | 1.0        | 1.1        |   3.0 | 40.00",
             "Neigh   | 0.1        | 0.2        | 0.3        |   1.0 |  8.00",
             "Other   |            | 0.5        |            |       | 20.00", "",
             "Nlocal:    2.5 ave 3 max 2 min",
             "Pair    | 9.0        | 9.0        | 9.0        |   0.0 | 99.00"]  # after the table: not timing
    timing = parse_timing(lines)
    assert timing == {"pair": 1.0, "neigh": 0.2, "comm": 0.0, "modify": 0.0, "output": 0.0, "other": 0.5,
                      "total": 2.5}


def test_warnings_counted(free_fall_run):
    scan = LammpsAdapter().scan_log(free_fall_run)
    assert scan.errors == []
    assert any("New thermo_style command" in w for w in scan.warnings)


def test_custom_dumps_read_as_vtk(free_fall_run):
    """Text dumps become one .vtp per snapshot; their kinetic energy (mass array) is the thermo's."""
    adapter = LammpsAdapter()
    files = adapter.vtk_files(free_fall_run)
    assert [f.name for f in files] == [f"particles_{s}.vtp" for s in (0, 250, 500, 750, 1000)]
    arrays = read_vtk_points(files[-1])
    assert {"v", "omega", "radius", "mass", "id", "type"} <= set(arrays)
    np.testing.assert_allclose(arrays["radius"], 0.0015)
    dumps = vtk_aggregates(files)
    assert list(dumps["particles"]) == [N_FREE_FALL] * 5
    for step, ke in zip(dumps["step"], dumps["ke"]):
        assert ke == pytest.approx(free_fall_ke(step), rel=1e-6)
    assert adapter.vtk_files(free_fall_run) == files  # converting again gives the same files
    snapshots = read_custom_dump(free_fall_run / "post" / "fall_0.dump")
    assert snapshots[0][0] == 0 and len(snapshots[0][2]) == N_FREE_FALL


def test_truncated_dump_keeps_complete_snapshots(free_fall_run, tmp_path):
    text = (free_fall_run / "post" / "fall_250.dump").read_text()
    path = tmp_path / "two.dump"
    path.write_text(text + text.replace("ITEM: TIMESTEP\n250", "ITEM: TIMESTEP\n300")[: len(text) // 2])
    assert [s[0] for s in read_custom_dump(path)] == [250]


def test_error_line_and_exit_code(tmp_path):
    (tmp_path / "in.bad").write_text(FREE_FALL.replace("fix             integrate all nve/sphere",
                                                       "fix             integrate all nve/spheroid"))
    result = run_lammps(tmp_path, "in.bad")
    assert result.returncode == 1
    scan = LammpsAdapter().scan_log(tmp_path)
    assert len(scan.errors) == 1 and scan.errors[0].startswith("ERROR: Unrecognized fix style 'nve/spheroid'")
    with pytest.raises(UserError, match=r"log\.lammps: no thermo output"):
        LammpsAdapter().read_thermo(tmp_path)


def test_missing_log_is_an_error(tmp_path):
    scan = LammpsAdapter().scan_log(tmp_path)
    assert scan.errors == ["log.lammps missing: LAMMPS did not start or could not open its log"]
    assert LammpsAdapter().vtk_files(tmp_path) == []


def test_no_rotational_energy_column_is_named(tmp_path):
    (tmp_path / "in.norot").write_text(FREE_FALL.replace("c_spin", "").replace("compute         spin all "
                                                                              "erotate/sphere\n", ""))
    assert run_lammps(tmp_path, "in.norot").returncode == 0
    with pytest.raises(UserError, match=r"no thermo column for 'rke' \(columns: Step, Atoms, KinEng\)"):
        LammpsAdapter().read_thermo(tmp_path)


def test_one_atom_kinetic_energy_needs_its_momentum_dof(tmp_path):
    """LAMMPS' KinEng is 1/2 dof kB T with dof = 3N - 3: zero for one atom unless extra/dof is 0."""
    one = FREE_FALL.replace("create_atoms    1 region fill", "create_atoms    1 single 0.0 0.0 0.04 units box")
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "in.one").write_text(one)
    run_lammps(tmp_path / "a", "in.one")
    assert (LammpsAdapter().read_thermo(tmp_path / "a")["ke"] == 0).all()
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "in.one").write_text(one.replace("thermo          100",
                                                       "thermo          100\ncompute_modify  thermo_temp extra/dof 0"))
    run_lammps(tmp_path / "b", "in.one")
    ke = LammpsAdapter().read_thermo(tmp_path / "b")["ke"]
    assert ke.iloc[0] == pytest.approx(0.5 * MASS * 0.1, rel=1e-7)


@needs_mpirun
def test_mpi_run_log(tmp_path):
    """Two ranks: the log says so, the thermo is the exact free fall, the timing table is parsed."""
    (tmp_path / "in.free_fall").write_text(FREE_FALL)
    result = run_lammps(tmp_path, "in.free_fall", nprocs=2)
    assert result.returncode == 0, result.stderr
    text = (tmp_path / "log.lammps").read_text()
    assert "Loop time of" in text and " on 2 procs for 500 steps" in text
    thermo = LammpsAdapter().read_thermo(tmp_path)
    for step, ke in zip(thermo["step"], thermo["ke"]):
        assert ke == pytest.approx(free_fall_ke(step), rel=1e-7)
    assert LammpsAdapter().read_timing(tmp_path)["total"] > 0
    assert len(LammpsAdapter().vtk_files(tmp_path)) == 5
