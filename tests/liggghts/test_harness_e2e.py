"""LIGGGHTS driven end to end through the harness CLI (subprocesses, a throw-away workspace)."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from liggghts_support import (
    FREE_FALL,
    LIGGGHTS,
    harness,
    needs_liggghts,
    needs_mpirun,
    records,
    series,
)

from harness.analysis.consistency import compare_runs, run_level

TUTORIALS = Path("/usr/share/doc/liggghts/examples/LIGGGHTS/Tutorials_public")
pytestmark = [needs_liggghts, pytest.mark.liggghts]


@pytest.fixture(scope="module")
def liggghts_target_runs(tmp_path_factory):
    """``harness run liggghts``: our three LIGGGHTS scenes, seven runs (about 6 s)."""
    home = tmp_path_factory.mktemp("home")
    result = harness(home, "run", "liggghts")
    return records(home, "liggghts"), result.stdout


@needs_mpirun
def test_liggghts_target_runs_all_scenes(liggghts_target_runs):
    runs, stdout = liggghts_target_runs
    assert sorted(runs) == [
        # three liggghts-doc tutorials as Debian installs them (targets/liggghts.json)
        "conveyor/conveyor", "mesh_tet/mesh_tet", "packing/packing",
        "testcases/liggghts/cohesion/cohesionless", "testcases/liggghts/cohesion/cohesive",
        "testcases/liggghts/settling/mpi_np2", "testcases/liggghts/settling/scaling@cores=1",
        "testcases/liggghts/settling/scaling@cores=2", "testcases/liggghts/settling/serial",
        "testcases/liggghts/wall_impact/impact",  # no run.config: the adapter's default one
    ]
    for name, record in runs.items():
        assert record["state"] == "post_processed", (name, record["failure_message"])
        assert record["adapter"] == "liggghts" and record["timing"]["total"] > 0
        if not name.startswith("testcases/"):
            continue  # the tutorials print their own thermo columns
        thermo = series(record, "thermo")
        assert {"step", "atoms", "ke", "rke"} <= set(thermo)


@needs_mpirun
def test_vtk_dumps_agree_with_thermo(liggghts_target_runs):
    """The backend's aggregates of LIGGGHTS' legacy .vtk dumps give the kinetic energy the log prints."""
    runs, _ = liggghts_target_runs
    for name in ("testcases/liggghts/settling/serial", "testcases/liggghts/wall_impact/impact"):
        thermo, dumps = series(runs[name], "thermo"), series(runs[name], "vtk")
        ke_by_step = dict(zip(thermo["step"], thermo["ke"]))
        assert len(dumps["step"]) >= 4
        for step, ke, count in zip(dumps["step"], dumps["ke"], dumps["particles"]):
            assert ke == pytest.approx(ke_by_step[step], rel=1e-6, abs=1e-12), (name, step)
            assert count == thermo["atoms"][0]


@needs_mpirun
def test_mpi_run_consistent_with_serial(liggghts_target_runs):
    runs, _ = liggghts_target_runs
    serial, mpi = runs["testcases/liggghts/settling/serial"], runs["testcases/liggghts/settling/mpi_np2"]
    command = mpi["command"]
    assert command[0] == "mpirun" and command[command.index("-np") + 1] == "2"
    assert "on 2 procs" in (Path(mpi["folder"]) / "log.liggghts").read_text()
    a, b = series(serial, "thermo"), series(mpi, "thermo")
    # identical until the decomposition's different summation order grows by chaos (late, small energies)
    np.testing.assert_allclose(b["ke"][:12], a["ke"][:12], rtol=1e-7)
    results = {r.quantity: r for r in compare_runs(mpi["series"], serial["series"])}
    assert results["ke"].level == "perfect" and results["rke"].level == "perfect"
    assert run_level(list(results.values()))[0] == "perfect"


def test_tutorials_run_unchanged(tmp_path):
    """A copy of Tutorials_public (two fast tutorials and the failing old-syntax script), no run.config."""
    if not TUTORIALS.is_dir():
        pytest.skip("LIGGGHTS tutorials not installed (apt-get install liggghts-doc)")
    tutorials = tmp_path / "Tutorials_public"
    for name in ("packing", "mesh_tet"):
        shutil.copytree(TUTORIALS / name, tutorials / name)
    (tutorials / "contactModels").mkdir()
    shutil.copy(TUTORIALS / "contactModels" / "in.oldModels", tutorials / "contactModels")
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "tutorials.json").write_text(json.dumps({
        "recipe": "system", "executable": LIGGGHTS, "engine": "liggghts", "testcases": [str(tutorials)]}))
    home = tmp_path / "home"
    result = harness(home, "run", "tutorials", targets=targets, check=False)
    assert result.returncode == 1  # one run failed
    runs = {name.rsplit("/", 2)[-2] + "/" + name.rsplit("/", 1)[-1]: r
            for name, r in records(home, "tutorials").items()}
    assert sorted(runs) == ["contactModels/oldModels", "mesh_tet/mesh_tet", "packing/packing"]
    packing = runs["packing/packing"]
    assert packing["state"] == "post_processed", packing["failure_message"]
    thermo = series(packing, "thermo")
    # three run blocks (run 1, run 50000, run 20000 upto) joined, steps strictly increasing
    assert thermo["step"][-1] == 70001 and np.all(np.diff(thermo["step"]) > 0)
    assert max(thermo["atoms"]) == 338 and max(thermo["rke"]) > 0  # rke: "compute 1 all erotate/sphere"
    assert len(series(packing, "vtk")["step"]) == 200
    assert runs["mesh_tet/mesh_tet"]["state"] == "post_processed"
    failed = runs["contactModels/oldModels"]
    assert failed["state"] == "failed" and "Invalid pair style" in failed["failure_message"]


def test_thermo_columns_from_run_config(tmp_path):
    """rke printed through an equal-style variable cannot be inferred; run.config's thermo_columns names it."""
    # the variable's column is "spinning", not the compute's "spin": rke cannot be inferred
    script = FREE_FALL.replace("thermo_style    custom step atoms ke c_spin\n",
                               "variable        spinning equal c_spin\n"
                               "thermo_style    custom step atoms ke v_spinning\n")
    script = script.replace("thermo_style    custom step atoms ke c_spin cpu\n", "")
    case = tmp_path / "cases" / "mapped"
    case.mkdir(parents=True)
    (case / "in.fall").write_text(script)
    runs = [{"name": "mapped", "script": "in.fall", "thermo_columns": {"rke": "v_spinning"}},
            {"name": "unmapped", "script": "in.fall"}]
    (case / "run.config").write_text(json.dumps({"runs": runs}))
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "mapped.json").write_text(json.dumps({
        "recipe": "system", "executable": LIGGGHTS, "engine": "liggghts", "testcases": [str(tmp_path / "cases")]}))
    home = tmp_path / "home"
    harness(home, "run", "mapped", targets=targets, check=False)
    runs = {name.rsplit("/", 1)[-1]: r for name, r in records(home, "mapped").items()}
    mapped, unmapped = runs["mapped"], runs["unmapped"]
    assert mapped["state"] == "post_processed", mapped["failure_message"]
    assert series(mapped, "thermo")["rke"] == [0.0] * 11
    # without the mapping: a one-line error that says what to do
    assert unmapped["state"] == "failed" and unmapped["failure_reason"] == "missing_output"
    assert "no thermo column for 'rke'" in unmapped["failure_message"]
    assert "thermo_columns" in unmapped["failure_message"] and "\n" not in unmapped["failure_message"]
