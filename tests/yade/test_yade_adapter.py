"""The YADE adapter with Debian's yade: the batch launcher (no TCP servers), the yade_series helper's thermo
against the exact free fall, variables, errors, VTKRecorder dumps read as VTK, parallel runs."""
from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import numpy as np
import pytest
from yade_testing import FALL, MASS, YADE, needs_yade, run_yade

from harness.adapters import get_adapter
from harness.adapters.base import UserError
from harness.adapters.yade import LAUNCHER, YadeAdapter, python_of
from harness.execution.postprocess import read_vtk_points, vtk_aggregates

pytestmark = [needs_yade, pytest.mark.yade]


def fall_ke(step: int) -> float:
    """Exact kinetic energy (J) of the two free spheres: m (|v0|^2 + (g t)^2), v0 = (0.3, 0.1, 0) m/s."""
    t = step * 1e-5
    return MASS * (0.3 ** 2 + 0.1 ** 2 + (9.81 * t) ** 2)


def test_command_line():
    adapter = get_adapter("yade")
    assert isinstance(adapter, YadeAdapter) and adapter.log_file() == "log.yade"
    assert adapter.accepts_script("scene.py") and not adapter.accepts_script("in.scene")
    python = python_of(YADE)
    assert python and Path(python).name.startswith("python3")
    assert adapter.command([YADE], "s.py", {"steps": 10, "e": 0.5}, "log.yade") == [
        python, str(LAUNCHER), "--log", "log.yade", YADE, "s.py", "steps=10", "e=0.5"]
    mpi = adapter.command([YADE], "s.py", {}, "log.yade", ["mpirun", "-np", "2"])
    assert mpi[mpi.index("--refuse") + 1].startswith("run type mpi: the harness runs YADE serially")


def test_thermo_is_the_exact_free_fall(fall_run):
    """Full-step velocities: ke at every sampled step equals the exact value to round-off."""
    thermo = YadeAdapter().read_thermo(fall_run)
    assert list(thermo["step"]) == list(range(0, 1001, 100))
    assert list(thermo.columns[:4]) == ["step", "atoms", "ke", "rke"] and "time" in thermo.columns
    assert (thermo["atoms"] == 2).all() and (thermo["rke"] == 0).all()
    for step, ke in zip(thermo["step"], thermo["ke"]):
        assert ke == pytest.approx(fall_ke(step), rel=1e-12)


def test_log_timing_and_no_tcp_server(fall_run):
    log = (fall_run / "log.yade").read_text()
    assert "YADE 2023.02a (" in log and "arguments ['steps=1000', 'label=first']" in log
    assert "label first listening sockets 0" in log and log.rstrip().endswith("exit code 0")
    timing = YadeAdapter().read_timing(fall_run)
    assert timing["total"] > 0 and timing["pair"] > 0 and timing["modify"] > 0 and timing["output"] > 0
    assert sum(timing[k] for k in ("pair", "neigh", "modify", "output", "other")) <= timing["total"] * 1.05
    assert YadeAdapter().scan_log(fall_run).errors == []


def test_plain_yade_batch_mode_opens_servers(tmp_path):
    """What the launcher avoids: 'yade -n -x' (the fallback for a launcher that is not a Python file)
    listens on two TCP ports, the Python prompt and the info server."""
    wrapper = tmp_path / "yade-wrapper"
    wrapper.write_text(f"#!/bin/sh\nexec {YADE} \"$@\"\n")
    wrapper.chmod(wrapper.stat().st_mode | stat.S_IXUSR)
    (tmp_path / "fall.py").write_text(FALL)
    (tmp_path / "post").mkdir()
    command = YadeAdapter().command([str(wrapper)], "fall.py", {"steps": 10}, "log.yade")
    assert command[:2] == ["env", f"PYTHONPATH={LAUNCHER.parent}"] and command[3:6] == ["-n", "-x", "fall.py"]
    process = run_yade(tmp_path, "fall.py", {"steps": 10, "label": "plain"}, executable=[str(wrapper)])
    assert process.returncode == 0
    assert "label plain listening sockets 2" in (tmp_path / "stdout.txt").read_text()


def test_parallel_runs(tmp_path):
    """Three runs at once, each in its own folder, all finish with their own thermo."""
    processes = []
    for i in range(3):
        folder = tmp_path / f"run{i}"
        (folder / "post").mkdir(parents=True)
        (folder / "fall.py").write_text(FALL)
        processes.append((folder, run_yade(folder, "fall.py", {"steps": 200 * (i + 1)}, wait=False)))
    for i, (folder, process) in enumerate(processes):
        assert process.wait(timeout=120) == 0
        assert YadeAdapter().read_thermo(folder)["step"].iloc[-1] == 200 * (i + 1)


def test_vtk_recorder_files_read_as_vtk(fall_run):
    files = YadeAdapter().vtk_files(fall_run)
    assert [f.name for f in files] == ["spheres_0.vtp", "spheres_500.vtp", "spheres_1000.vtp"]
    arrays = read_vtk_points(files[1])
    assert {"v", "radius", "mass"} <= set(arrays)
    np.testing.assert_allclose(arrays["radius"].reshape(-1), 0.0015)
    dumps = vtk_aggregates(files)
    assert list(dumps["particles"]) == [2, 2, 2]
    # VTKRecorder (after NewtonIntegrator) writes the leap-frog velocity of step N + 1/2 under the name N
    for step, ke in zip(dumps["step"], dumps["ke"]):
        assert ke == pytest.approx(fall_ke(step + 0.5), rel=1e-9)


def test_script_error_fails_with_its_line(tmp_path):
    (tmp_path / "bad.py").write_text("import yade_series\nx = 1\nO.bodies.append(sphere((0, 0, 0), -1.0))\n"
                                     "raise ValueError('scene not built')\n")
    process = run_yade(tmp_path, "bad.py")
    assert process.returncode == 1
    scan = YadeAdapter().scan_log(tmp_path)
    assert scan.errors == ["ERROR: ValueError: scene not built (bad.py line 4)"]
    with pytest.raises(UserError, match=r"thermo\.csv: no thermo output \(a YADE script writes it with the "
                                        r"yade_series helper"):
        YadeAdapter().read_thermo(tmp_path)


def test_bad_variable_value_stops_the_script(tmp_path):
    (tmp_path / "fall.py").write_text(FALL)
    process = run_yade(tmp_path, "fall.py", {"steps": "many", "other_code_variable": 3})
    assert process.returncode == 1
    assert YadeAdapter().scan_log(tmp_path).errors == ["ERROR: variable steps='many': not a int"]


def test_mpi_run_refused_with_reason(tmp_path):
    (tmp_path / "fall.py").write_text(FALL)
    process = run_yade(tmp_path, "fall.py", mpi=["mpirun", "-np", "2"])
    assert process.returncode == 1
    assert YadeAdapter().scan_log(tmp_path).errors[0].startswith("ERROR: run type mpi: the harness runs YADE "
                                                                 "serially")


def test_default_run_config_one_run_per_script(tmp_path):
    (tmp_path / "b.py").write_text("")
    (tmp_path / "a.py").write_text("")
    (tmp_path / "notes.txt").write_text("")
    assert YadeAdapter().default_run_config(tmp_path) == {"runs": [
        {"name": "a", "type": "serial", "script": "a.py"}, {"name": "b", "type": "serial", "script": "b.py"}]}
    assert YadeAdapter().default_run_config(tmp_path / "nothing") is None
