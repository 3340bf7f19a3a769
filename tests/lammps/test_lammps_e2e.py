"""LAMMPS driven end to end through the harness CLI (subprocesses, a throw-away workspace)."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from lammps_support import (
    EXAMPLES,
    harness,
    needs_lammps,
    needs_mpirun,
    records,
    series,
)

from harness.analysis.consistency import compare_runs, run_level

pytestmark = [needs_lammps, pytest.mark.lammps]


@pytest.fixture(scope="module")
def lammps_target(tmp_path_factory):
    """``harness run lammps`` (three runs, one on 2 MPI ranks, about 5 s) and ``harness check lammps``."""
    home = tmp_path_factory.mktemp("home")
    run = harness(home, "run", "lammps", "-j", "2")
    check = harness(home, "check", "lammps", check=False)
    return records(home, "lammps"), run, check


@needs_mpirun
def test_every_run_post_processed(lammps_target):
    runs, _, check = lammps_target
    assert sorted(runs) == ["testcases/lammps/hooke_wall/bounce", "testcases/lammps/settling/mpi_np2",
                            "testcases/lammps/settling/serial"]
    for name, record in runs.items():
        assert record["state"] == "post_processed", (name, record["failure_message"])
        assert record["adapter"] == "lammps" and record["timing"]["total"] > 0
        assert {"step", "atoms", "ke", "rke"} <= set(series(record, "thermo"))
    assert check.returncode == 0, check.stdout + check.stderr


@needs_mpirun
def test_hooke_bounce_against_the_damped_oscillator(lammps_target):
    """Contact time pi/w and restitution exp(-gamma_n pi / (2 w)) of a linear spring-dashpot wall."""
    runs, _, _ = lammps_target
    record = runs["testcases/lammps/hooke_wall/bounce"]
    mass = 4.0 / 3.0 * np.pi * 0.0015 ** 3 * 2500
    w = np.sqrt(200.0 / mass - (1000.0 / 2) ** 2)
    values = (Path(record["folder"]) / "bounce.txt").read_text().split()
    contact_time, restitution = float(values[2]), float(values[3])
    assert contact_time == pytest.approx(np.pi / w, abs=1.5e-5)
    assert restitution == pytest.approx(np.exp(-500.0 * np.pi / w), rel=0.01)
    assert all(v["ok"] for v in record["verdicts"])


@needs_mpirun
def test_mpi_run_consistent_with_serial(lammps_target):
    runs, _, _ = lammps_target
    serial, mpi = runs["testcases/lammps/settling/serial"], runs["testcases/lammps/settling/mpi_np2"]
    assert mpi["command"][0] == "mpirun" and mpi["command"][mpi["command"].index("-np") + 1] == "2"
    assert "on 2 procs" in (Path(mpi["folder"]) / "log.lammps").read_text()
    a, b = series(serial, "thermo"), series(mpi, "thermo")
    np.testing.assert_allclose(b["ke"][:10], a["ke"][:10], rtol=1e-7)
    results = {r.quantity: r for r in compare_runs(mpi["series"], serial["series"])}
    assert results["ke"].level == "perfect" and results["atoms"].level == "perfect"
    assert run_level(list(results.values()))[0] in ("perfect", "good")


@needs_mpirun
def test_dumps_agree_with_thermo(lammps_target):
    runs, _, _ = lammps_target
    record = runs["testcases/lammps/settling/serial"]
    thermo, dumps = series(record, "thermo"), series(record, "vtk")
    ke_by_step = dict(zip(thermo["step"], thermo["ke"]))
    assert dumps["step"] == [0, 500, 1000, 1500, 2000, 2500, 3000]
    for step, ke, count in zip(dumps["step"], dumps["ke"], dumps["particles"]):
        assert ke == pytest.approx(ke_by_step[step], rel=1e-6)
        assert count == 144


def test_shipped_example_runs_unchanged(tmp_path):
    """A copy of examples/granregion (no run.config: one run per in.* script); in.granregion.box prints
    temperatures, not the kinetic energy, and fails naming the column and the log."""
    if not (EXAMPLES / "granregion").is_dir():
        pytest.skip("LAMMPS examples not installed (apt-get install lammps-examples)")
    folder = tmp_path / "granregion"
    folder.mkdir()
    shutil.copy(EXAMPLES / "granregion" / "in.granregion.box", folder)
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "examples.json").write_text(json.dumps({
        "recipe": "system", "executable": "/usr/bin/lmp", "engine": "lammps", "testcases": [str(folder)]}))
    home = tmp_path / "home"
    result = harness(home, "run", "examples", targets=targets, check=False)
    assert result.returncode == 1
    record = records(home, "examples")["granregion/granregion.box"]
    assert record["state"] == "failed" and record["failure_reason"] == "missing_output"
    assert "log.lammps: no thermo column for 'ke' (columns: Step, Atoms, Temp, c_1, c_2, Press)" \
        in record["failure_message"]
    assert record["exit_code"] == 0 and record["timing"]["total"] > 0
