"""The LIGGGHTS adapter on crafted log texts (edge cases real runs rarely produce) and test case folders."""
from __future__ import annotations

import os

import pytest

from harness.adapters.base import UserError, is_open_mpi
from harness.adapters.base import with_open_mpi_flags as mpi_prefix
from harness.adapters.liggghts import LOG_NAME, LiggghtsAdapter

adapter = LiggghtsAdapter()

# Two blocks with insertion reports and warnings inside the table, a step repeated at the block boundary,
# a compute named "rot" (header "rot"), a NaN, and an ERROR after a run that still "succeeded" (exit 0).
CRAFTED = """\
LIGGGHTS (Version LIGGGHTS-PUBLIC 3.8.0)
compute rot all erotate/sphere
thermo_style custom step atoms ke c_rot vol
run 20
Setting up run at Sat Nov 21 10:00:00 2026

Memory usage per processor = 4.8 Mbytes
    Step    Atoms         KinEng            rot         Volume 
       0        0              0              0         0.0015 
INFO: Particle insertion ins: inserted 250 particle templates (mass 8.835729e-03) at step 1
 - a total of 250 particle templates (mass 8.835729e-03) inserted so far.
      10      250         0.0002          1e-06         0.0015 
WARNING: time-step is 5.294149 % of rayleigh time (./src/fix_check_timestep_gran.cpp:200)
      20      250         0.0003          2e-06         0.0015 
Loop time of 0.5 on 1 procs for 20 steps with 250 atoms, finish time Sat Nov 21 10:00:01 2026


Pair  time (%) = 0.25 (50)
Neigh time (%) = 0.05 (10)
Comm  time (%) = 0.05 (10)
Outpt time (%) = 0.05 (10)
Modify time (%) = 0.05 (10)
Other time (%) = 0.05 (10)

Nlocal:    250 ave 250 max 250 min
run 20
Setting up run at Sat Nov 21 10:00:01 2026

Memory usage per processor = 4.8 Mbytes
    Step    Atoms         KinEng            rot         Volume 
      20      250         0.0003          2e-06         0.0015 
      30      250            nan          3e-06         0.0015 
WARNING: Particle lost
      40      249         0.0004          4e-06         0.0015 
Loop time of 0.25 on 1 procs for 20 steps with 249 atoms, finish time Sat Nov 21 10:00:02 2026


Pair  time (%) = 0.2 (80)
Neigh time (%) = 0 (0)
Comm  time (%) = 0 (0)
Outpt time (%) = 0 (0)
Other time (%) = 0.05 (20)
ERROR: Lost atoms: original 250 current 249 (./src/thermo.cpp:398)
"""


@pytest.fixture
def crafted(tmp_path):
    (tmp_path / LOG_NAME).write_text(CRAFTED)
    return tmp_path


def test_blocks_joined_repeated_step_dropped(crafted):
    thermo = adapter.read_thermo(crafted)
    assert list(thermo["step"]) == [0, 10, 20, 30, 40]
    assert list(thermo["atoms"]) == [0, 250, 250, 250, 249]
    assert list(thermo["rke"]) == [0, 1e-6, 2e-6, 3e-6, 4e-6]  # inferred from "compute rot ... erotate/sphere"
    assert thermo["ke"].isna().sum() == 1  # NaN kept for the harness' non-finite check
    assert list(thermo.columns[:4]) == ["step", "atoms", "ke", "rke"] and "Volume" in thermo.columns


def test_numeric_compute_id(tmp_path):
    # Tutorials_public/packing: "compute 1 all erotate/sphere" is printed as header column "1"
    (tmp_path / LOG_NAME).write_text(CRAFTED.replace(" rot ", " 1 ").replace("c_rot", "c_1")
                                     .replace("            rot ", "              1 "))
    thermo = adapter.read_thermo(tmp_path)
    assert list(thermo["rke"]) == [0, 1e-6, 2e-6, 3e-6, 4e-6]


def test_explicit_mapping_wins(crafted):
    # KinEng would be inferred for ke; the mapping names another column and wins
    thermo = adapter.read_thermo(crafted, {"ke": "Volume"})
    assert (thermo["ke"] == 0.0015).all()
    assert "KinEng" in thermo.columns  # the unmapped log column is still there under its own name


def test_mapping_onto_prefixed_compute_name(crafted):
    thermo = adapter.read_thermo(crafted, {"rke": "c_rot"})
    assert thermo["rke"].iloc[-1] == 4e-6
    thermo = adapter.read_thermo(crafted, {"rke": "Volume"})
    assert (thermo["rke"] == 0.0015).all()


def test_unknown_mapped_column_is_one_line_error(crafted):
    with pytest.raises(UserError) as error:
        adapter.read_thermo(crafted, {"ke": "c_nothere"})
    message = str(error.value)
    assert "\n" not in message and LOG_NAME in message and "thermo_columns.ke" in message
    assert "KinEng" in message  # lists the columns there are


def test_missing_rke_without_mapping_is_error(tmp_path):
    (tmp_path / LOG_NAME).write_text(CRAFTED.replace("erotate/sphere", "ke/atom").replace(" rot ", " foo "))
    with pytest.raises(UserError, match="no thermo column for 'rke'"):
        adapter.read_thermo(tmp_path)


def test_timing_sums_blocks_including_modify(crafted):
    timing = adapter.read_timing(crafted)
    assert timing == pytest.approx({"pair": 0.45, "neigh": 0.05, "comm": 0.05, "output": 0.05,
                                    "modify": 0.05, "other": 0.1, "total": 0.75})


def test_error_fails_even_with_exit_code_zero(crafted):
    scan = adapter.scan_log(crafted)
    assert scan.errors == ["ERROR: Lost atoms: original 250 current 249 (./src/thermo.cpp:398)"]
    assert len(scan.warnings) == 2


def test_error_of_other_rank_found_on_screen(crafted):
    # ranks other than 0 write their errors only to the screen (captured as stdout by the harness)
    (crafted / "stdout.txt").write_text("ERROR on proc 1: Bond atom missing (./src/ntopo.cpp:100)\n"
                                        "ERROR: Lost atoms: original 250 current 249 (./src/thermo.cpp:398)\n")
    scan = adapter.scan_log(crafted)
    assert scan.errors[1] == "ERROR on proc 1: Bond atom missing (./src/ntopo.cpp:100)"
    assert len(scan.errors) == 2  # rank 0's error in log and on screen counts once


def test_stray_bytes_on_screen(crafted):
    # seen from LIGGGHTS 3.8.0: after an ERROR the screen sometimes gets a line of uninitialised bytes
    (crafted / "stdout.txt").write_bytes(b"ERROR: Unknown command: frobnicate all (./src/input.cpp:259)\n"
                                         b"\x19\xb7\x19_\x05 (./src/input.cpp:259)\n")
    scan = adapter.scan_log(crafted)
    assert scan.errors[-1] == "ERROR: Unknown command: frobnicate all (./src/input.cpp:259)"


def test_missing_log(tmp_path):
    assert adapter.scan_log(tmp_path).errors[0].startswith(f"{LOG_NAME} missing")
    with pytest.raises(UserError, match=LOG_NAME):
        adapter.read_thermo(tmp_path)
    assert adapter.vtk_files(tmp_path) == []


def test_no_thermo_table(tmp_path):
    (tmp_path / LOG_NAME).write_text("LIGGGHTS (Version LIGGGHTS-PUBLIC 3.8.0)\nunits si\n")
    with pytest.raises(UserError, match="no thermo output"):
        adapter.read_thermo(tmp_path)


def test_vtk_files_from_dump_commands(tmp_path):
    (tmp_path / LOG_NAME).write_text(
        "dump d all custom/vtk 100 ${name}_*.vtk id\n"
        "dump d all custom/vtk 100 post/p_*.vtk id x y z\n"
        "dump m all mesh/vtk 100 post/mesh_*.vtk id\n")
    (tmp_path / "post").mkdir()
    for name in ("p_0.vtk", "p_1000.vtk", "p_200.vtk", "p_boundingBox_0.vtk", "mesh_0.vtk", "p_x.vtk"):
        (tmp_path / "post" / name).write_text("")
    assert [p.name for p in adapter.vtk_files(tmp_path)] == ["p_0.vtk", "p_200.vtk", "p_1000.vtk"]


def test_accepts_only_liggghts_scripts():
    assert adapter.accepts_script("in.settling") and adapter.accepts_script("settling.in")
    assert not adapter.accepts_script("scene.json")


def test_command_line():
    assert adapter.command(["/usr/bin/liggghts"], "in.scene", {"N": 10, "dt": "1e-5"}, "log.liggghts") == [
        "/usr/bin/liggghts", "-in", "in.scene", "-var", "N", "10", "-var", "dt", "1e-5", "-log", "log.liggghts"]


def test_mpi_flags_only_where_needed():
    cores = os.cpu_count() or 1
    many = mpi_prefix(["mpirun", "-np", str(cores + 1)])
    few = mpi_prefix(["mpirun", "-np", "1"])
    if is_open_mpi("mpirun"):
        assert ("--allow-run-as-root" in few) == (os.geteuid() == 0)
        assert "--oversubscribe" in many and "--oversubscribe" not in few
        assert many[0] == "mpirun" and many[-2:] == ["-np", str(cores + 1)]
    # flags are never doubled, other launchers are untouched
    assert mpi_prefix(["mpirun", "--allow-run-as-root", "-np", "1"]).count("--allow-run-as-root") <= 1
    assert mpi_prefix(["srun", "-n", "64"]) == ["srun", "-n", "64"]


def test_default_run_config(tmp_path):
    assert adapter.default_run_config(tmp_path) is None
    (tmp_path / "in.init").write_text("run 10\nwrite_restart post/restart/state.restart\n")
    (tmp_path / "in.run").write_text("read_restart post/restart/state.restart\nrun 10\n")
    (tmp_path / "in.other").write_text("run 10\n")
    (tmp_path / "in.other~").write_text("run 10\n")  # editor backup, not a script
    assert adapter.default_run_config(tmp_path) == {"runs": [
        {"name": "init", "type": "serial", "script": "in.init"},
        {"name": "other", "type": "serial", "script": "in.other"},
        {"name": "run", "type": "serial", "script": "in.run", "depends_on": "init"},
    ]}
