"""The parts of efficiency one by one: scaling figures against Amdahl's law, the scaling block's expansion and
its problems, every adapter's breakdown (real LAMMPS on 2 ranks), folding perf script output, and the
profile and breakdown diffs."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
from collections import Counter
from pathlib import Path

import pytest

from harness.analysis import breakdown as bd
from harness.analysis import scaling
from harness.execution import profiles

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("serial", [0.0, 0.05, 0.3])
def test_karp_flatt_recovers_the_serial_fraction_of_amdahls_law(serial):
    # Amdahl: T(P) = T1 (f + (1 - f)/P); the Karp-Flatt metric is f at every P
    points = [scaling.ScalingPoint(p, 12.0 * (serial + (1 - serial) / p)) for p in (1, 2, 3, 8)]
    for point in scaling.figures(points):
        speedup = 1 / (serial + (1 - serial) / point.cores)
        assert point.speedup == pytest.approx(speedup)
        assert point.efficiency == pytest.approx(speedup / point.cores)
        if point.cores > 1:
            assert point.serial_fraction == pytest.approx(serial, abs=1e-12)
        else:
            assert point.serial_fraction is None


def test_weak_scaling_speedup_is_scaled_by_the_cores():
    # the size doubles with the cores; 10 % more time on 2 cores: scaled speedup 2/1.1, efficiency 1/1.1
    one, two = scaling.figures([scaling.ScalingPoint(2, 11.0), scaling.ScalingPoint(1, 10.0)], "weak")
    assert (one.cores, two.cores) == (1, 2)
    assert two.speedup == pytest.approx(2 / 1.1) and two.efficiency == pytest.approx(1 / 1.1)


def test_a_failed_point_has_no_figures_and_the_others_keep_theirs():
    points = scaling.figures([scaling.ScalingPoint(1, 10.0), scaling.ScalingPoint(2, None, "failed"),
                              scaling.ScalingPoint(4, 5.0)])
    assert points[1].speedup is None and points[2].speedup == 2.0 and points[2].efficiency == 0.5


def test_a_build_that_scales_worse_is_marked_against_the_previous_one():
    rows = [{"cores": 2, "efficiency": e} for e in (0.9, 0.85, 0.7, 0.72)] + [{"cores": 4, "efficiency": 0.5}]
    assert [r["worse"] for r in scaling.mark_worse(rows)] == [False, False, True, False, False]


def test_scaling_block_expands_to_mpi_ranks_or_threads_with_the_weak_variable():
    entry = {"name": "bed", "script": "in.bed", "scaling": {"cores": [1, 2, 4], "kind": "weak",
                                                            "with": {"N": [1000, 2000, 4000]}}}
    ranks = scaling.expand(entry, "mpi")
    assert [p["name"] for p in ranks] == ["bed@cores=1", "bed@cores=2", "bed@cores=4"]
    assert [(p["type"], p["nprocs"], p["variables"]["N"]) for p in ranks] == [
        ("mpi", 1, 1000), ("mpi", 2, 2000), ("mpi", 4, 4000)]
    threads = scaling.expand(entry, "threads")
    assert "type" not in threads[1] and scaling.thread_environment(threads[1]) == {
        "NUMBA_NUM_THREADS": "2", "OMP_NUM_THREADS": "2"}
    assert scaling.thread_environment(ranks[1]) == {}


def test_scaling_problems_are_one_line_each_with_their_json_path(tmp_path):
    from harness.adapters import get_adapter
    from harness.config.testcases import load_testcase

    (tmp_path / "scene.json").write_text("[]")
    (tmp_path / "run.config").write_text(json.dumps({"runs": [
        {"name": "a", "script": "scene.json", "scaling": {"cores": [1]}},
        {"name": "b", "script": "scene.json", "scaling": {"cores": [1, 2], "kind": "weak"}},
        {"name": "c", "script": "scene.json", "scaling": {"cores": [1, 2]}, "profile": {"call_graph": "lbr"}},
        {"name": "d", "script": "scene.json", "scaling": {"cores": [1, 2]}, "profile": True}]}))
    spec = load_testcase(tmp_path, "case", get_adapter("dem"))
    problems = {run.name: run.problems for run in spec.runs}
    assert "$.runs[0].scaling.cores: must be a list of at least two core counts" in problems["a"][0]
    assert "$.runs[1].scaling.with: a weak scaling study grows the size" in problems["b"][0]
    assert "$.runs[2].profile.call_graph: must be one of dwarf, fp" in problems["c@cores=1"][0]
    assert problems["d@cores=1"] == [] and problems["d@cores=2"] == []


@pytest.mark.skipif(shutil.which("lmp") is None or shutil.which("mpirun") is None, reason="needs Debian lammps")
def test_lammps_breakdown_has_min_avg_max_over_two_ranks_and_the_pair_imbalance(tmp_path):
    from harness.adapters.base import with_open_mpi_flags
    from harness.adapters.lammps import LammpsAdapter

    shutil.copy(ROOT / "testcases" / "lammps" / "settling" / "in.settling", tmp_path)
    (tmp_path / "post").mkdir()
    subprocess.run(with_open_mpi_flags(["mpirun", "-np", "2"]) + ["lmp", "-in", "in.settling", "-var", "steps", "1000",
                                                                 "-log", "log.lammps"],
                   cwd=tmp_path, check=True, capture_output=True, timeout=300)
    log = (tmp_path / "log.lammps").read_text()
    found = LammpsAdapter().read_breakdown(tmp_path)
    assert found["ranks"] == 2
    # independently: sum each section row's min/avg/max over the run blocks of LAMMPS' own table
    expected: dict = {}
    for name, mn, avg, mx in re.findall(r"^(Pair|Neigh|Comm)\s*\|\s*(\S+)\s*\|\s*(\S+)\s*\|\s*(\S+)\s*\|", log, re.M):
        key = {"Pair": "pair", "Neigh": "neighbor", "Comm": "communication"}[name]
        for stat, value in zip(("min", "avg", "max"), (mn, avg, mx)):
            expected.setdefault(key, {}).setdefault(stat, 0.0)
            expected[key][stat] += float(value)
    for key, stats in expected.items():
        assert found["sections"][key] == pytest.approx(stats)
    assert found["total"] == pytest.approx(sum(float(t) for t in re.findall(r"^Loop time of (\S+)", log, re.M)))
    assert found["imbalance"] == pytest.approx(expected["pair"]["max"] / expected["pair"]["avg"])
    assert found["imbalance_of"] == "pair time"


PERF_SCRIPT = """\
mini 4242 1000.000100:    1001001 cpu-clock:ppp:
\t    1189 compute_pair_forces+0x29 (/tmp/mini)
\t    1420 main+0x1b4 (/tmp/mini)
\t   29d8f __libc_start_call_main+0x7f (/usr/lib/x86_64-linux-gnu/libc.so.6)

mini 4242 1000.001100:    1001001 cpu-clock:ppp:
\t    1189 compute_pair_forces+0x29 (/tmp/mini)
\t    1420 main+0x1b4 (/tmp/mini)
\t   29d8f __libc_start_call_main+0x7f (/usr/lib/x86_64-linux-gnu/libc.so.6)

mini 4242 1000.002100:    1001001 cpu-clock:ppp:
\t   12345 [unknown] (/usr/lib/x86_64-linux-gnu/libm.so.6)
\t    1500 integrate+0x10 (/tmp/mini)
\t    1420 main+0x1b4 (/tmp/mini)
\t   29d8f __libc_start_call_main+0x7f (/usr/lib/x86_64-linux-gnu/libc.so.6)
"""


def test_perf_script_output_folds_into_root_first_stacks(tmp_path):
    stacks = profiles.fold_perf_script(PERF_SCRIPT)
    assert stacks == Counter({"mini;__libc_start_call_main;main;compute_pair_forces": 2,
                              "mini;__libc_start_call_main;main;integrate;[libm.so.6]": 1})
    profiles.write_folded(tmp_path / "profile.folded", stacks)
    assert profiles.read_folded(tmp_path / "profile.folded") == stacks
    shares = profiles.function_shares(stacks)
    assert shares["main"] == (1.0, 0.0) and shares["compute_pair_forces"] == (pytest.approx(2 / 3),) * 2


def test_profile_diff_puts_the_function_that_grew_first_and_tree_values_add_up():
    a = Counter({"x;main;pair": 20, "x;main;neighbor": 60, "x;main;integrate": 20})
    b = Counter({"x;main;pair": 80, "x;main;neighbor": 60, "x;main;integrate": 20})
    rows = profiles.function_diff(a, b)
    assert rows[0]["function"] == "pair" and rows[0]["growth"] == pytest.approx(0.5 - 0.2)
    assert rows[-1]["function"] == "neighbor"
    tree = profiles.tree(b)
    assert tree["value"] == 160 and tree["children"][0]["children"][0]["value"] == 160
    diff = profiles.diff_tree(a, b)
    leaves = {c["name"]: c["delta"] for c in diff["children"][0]["children"][0]["children"]}
    # A scaled to B's 160 samples: pair 32 -> 80, neighbor 96 -> 60, integrate 32 -> 20
    assert leaves == {"pair": 48.0, "neighbor": -36.0, "integrate": -12.0}


def test_breakdown_diff_names_the_section_that_grew_and_its_part_of_the_growth():
    a = bd.from_timing({"pair": 1.0, "neigh": 0.5, "comm": 0.0, "modify": 0.2, "output": 0.1, "other": 0.2,
                        "total": 2.0})
    b = bd.from_timing({"pair": 1.1, "neigh": 0.5, "comm": 0.0, "modify": 0.2, "output": 1.1, "other": 0.1,
                        "total": 3.0})
    rows = bd.diff(a, b)
    assert rows[0]["section"] == "output" and rows[0]["delta"] == pytest.approx(1.0)
    assert rows[0]["of_growth"] == pytest.approx(1.0) and rows[-1]["section"] == "other"
    assert bd.from_timing({}) == {}


def test_without_perf_a_profiled_run_runs_unprofiled_and_says_why(monkeypatch, tmp_path):
    from harness.adapters import get_adapter
    from harness.store.runrecord import RunSpec

    def liggghts_run() -> RunSpec:
        return RunSpec(machine="m", target="t", target_definition={}, build={}, testcase="c", run="r",
                       testcase_hash="", config={}, adapter="liggghts", thermo_columns={}, environment={},
                       workspace=str(tmp_path), folder=str(tmp_path), source_folder=str(tmp_path), files=[],
                       command=["liggghts", "-in", "in.x"])

    spec = liggghts_run()
    profiles.enable(spec, get_adapter("liggghts"), True)
    assert spec.command[:5] == ["perf", "record", "-g", "--call-graph", "dwarf"]
    monkeypatch.setattr(profiles.shutil, "which", lambda name: None)  # a machine without linux-perf
    spec = liggghts_run()
    profiles.enable(spec, get_adapter("liggghts"), {"call_graph": "fp"})
    assert spec.command == ["liggghts", "-in", "in.x"]
    record = spec.record()
    profiles.finish(spec, tmp_path, record)
    assert record.warnings == ["WARNING: no profile: perf is not installed (Debian: linux-perf)"]
    assert record.profile == ""
