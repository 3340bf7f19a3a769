"""Bad input files and process faults in the harness: one-line errors or documented behaviour, never a
traceback, never a lost record.

Most cases run the real CLI (``python -m harness.cli``) in a subprocess on a throw-away workspace, with the
fake engine of ``tests/harness/fake_engine`` committed to a temporary git repository, and read the store
back with ``sqlite3`` (the very file the harness wrote). Validation details that need no process are tested
in-process on the parsing functions.

Groups: JSON inputs (non-finite numbers, wrong types), names (targets, test case folders, runs), reference
cycles, post scripts that leave children behind, and a workspace or store that cannot be written.
"""
from __future__ import annotations

import json
import os
import shutil
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from harness.adapters.base import UserError

REPO = Path(__file__).resolve().parents[2]
FAKE_ENGINE = REPO / "tests" / "harness" / "fake_engine" / "__main__.py"
SCENE = [{"command": "create", "heights": [1.0]}, {"command": "run", "steps": 100, "every": 20}]
GOOD = '{"name": "good", "script": "scene.json"}'


# ------------------------------------------------------------------------------------------------ helpers

def _git(folder: Path, *args: str) -> None:
    subprocess.run(["git", "-C", str(folder), *args], check=True, capture_output=True)


class Project:
    """A git repository holding the fake engine, a targets folder and a folder of test cases (read as they
    are: an absolute ``testcases`` entry), and a workspace ``home``."""

    def __init__(self, root: Path):
        self.root = root
        self.repo = root / "repo"
        (self.repo / "engine").mkdir(parents=True)
        (self.repo / "engine" / "__init__.py").write_text("")
        (self.repo / "engine" / "__main__.py").write_text(FAKE_ENGINE.read_text())
        _git(self.repo, "init", "-q")
        _git(self.repo, "add", "-A")
        _git(self.repo, "-c", "user.name=t", "-c", "user.email=t@example.org", "commit", "-qm", "engine")
        self.targets = root / "targets"
        self.targets.mkdir()
        self.cases = root / "cases"
        self.cases.mkdir()
        self.home = root / "home"
        self.write_target("t")

    def write_target(self, name: str, text: str | None = None, **fields) -> Path:
        path = self.targets / f"{name}.json"
        path.write_text(text if text is not None else json.dumps(
            {"repository": str(self.repo), "testcases": [str(self.cases)], **fields}))
        return path

    def write_case(self, name: str, runs_text: str, folder: Path | None = None) -> Path:
        """A test case folder with the scene and a run.config whose ``runs`` list is ``runs_text`` (JSON
        text, so that NaN, Infinity and 1e400 can be written as a user would)."""
        case = (folder or self.cases) / name
        case.mkdir(parents=True, exist_ok=True)
        (case / "scene.json").write_text(json.dumps(SCENE))
        config = case / "run.config"
        config.write_text('{"runs": [' + runs_text + "]}\n")
        return config

    def harness(self, *args: str, home: Path | None = None, timeout: float = 180) -> subprocess.CompletedProcess:
        env = {k: v for k, v in os.environ.items()
               if k not in ("HARNESS_TARGETS", "HARNESS_MACHINE", "HARNESS_DATABASE_URL", "DJANGO_SETTINGS_MODULE")}
        env["HARNESS_HOME"] = str(home or self.home)
        return subprocess.run([sys.executable, "-m", "harness.cli", "--home", str(home or self.home),
                               "--targets", str(self.targets), "--machine", "m", *args],
                              cwd=REPO, env=env, capture_output=True, text=True, timeout=timeout)

    def runs(self, database: Path | None = None) -> dict:
        return stored_runs(database or self.home / "harness.sqlite3")


def stored_runs(database: Path) -> dict:
    """``{(target, test case, run): row}`` as the store holds them."""
    with sqlite3.connect(database) as db:
        db.row_factory = sqlite3.Row
        rows = db.execute("SELECT t.name AS target, c.path AS testcase, r.name AS run, r.state, "
                          "r.failure_reason AS reason, r.failure_message AS message FROM harness_run r "
                          "JOIN harness_target t ON t.id = r.target_id "
                          "JOIN harness_testcase c ON c.id = r.testcase_id").fetchall()
    return {(r["target"], r["testcase"], r["run"]): dict(r) for r in rows}


def assert_clean(result: subprocess.CompletedProcess) -> None:
    """No traceback, and every error the harness printed is a single ``harness: error:`` line."""
    assert "Traceback" not in result.stderr, result.stderr[-4000:]
    assert "Traceback" not in result.stdout, result.stdout[-4000:]


def one_error_line(result: subprocess.CompletedProcess) -> str:
    assert_clean(result)
    assert result.returncode != 0, result.stdout + result.stderr
    lines = [line for line in result.stderr.splitlines() if line.startswith("harness: error:")]
    assert len(lines) == 1, result.stderr[-4000:]
    return lines[0]


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    """One project and workspace for the many run.config cases (each selects its own folder with -k)."""
    return Project(tmp_path_factory.mktemp("inputs"))


@pytest.fixture
def project(tmp_path):
    return Project(tmp_path)


# ---------------------------------------------------------------------- 1. JSON inputs: one broken entry

#: a run.config entry (JSON text) that must fail alone with reason config, and the JSON path the message
#: names (plus text it must contain)
BAD_ENTRIES = {
    "timeout_nan": ('"timeout": NaN', "$.runs[1].timeout", "NaN"),
    "timeout_infinity": ('"timeout": Infinity', "$.runs[1].timeout", "Infinity"),
    "timeout_minus_infinity": ('"timeout": -Infinity', "$.runs[1].timeout", "-Infinity"),
    "timeout_1e400": ('"timeout": 1e400', "$.runs[1].timeout", "1e400"),
    "timeout_huge_integer": ('"timeout": 1' + "0" * 400, "$.runs[1].timeout", "too large"),
    "timeout_text": ('"timeout": "ten"', "$.runs[1].timeout", "number"),
    "nprocs_bool": ('"type": "mpi", "nprocs": true', "$.runs[1].nprocs", "integer"),
    "nprocs_1e400": ('"type": "mpi", "nprocs": 1e400', "$.runs[1].nprocs", "1e400"),
    "variable_null": ('"variables": {"X": null}', "$.runs[1].variables.X", "string or number"),
    "variable_nan": ('"variables": {"X": NaN}', "$.runs[1].variables.X", "NaN"),
    "variables_list": ('"variables": ["X"]', "$.runs[1].variables", "object"),
    "post_scripts_string": ('"post_scripts": "a.sh"', "$.runs[1].post_scripts", "list"),
    "depends_on_number": ('"depends_on": 3', "$.runs[1].depends_on", "run name"),
    "epsilon_text": ('"consistency": {"ke": {"epsilon": "x"}}', "$.runs[1].consistency.ke.epsilon", "number"),
    "expectations_object": ('"expectations": {"quantity": "thermo.ke"}', "$.runs[1].expectations", "list"),
    "expectation_bound_text": ('"expectations": [{"quantity": "thermo.ke", "upper": "big"}]',
                               "$.runs[1].expectations[0].upper", "number"),
    "stability_list": ('"stability": [1]', "$.runs[1].stability", "object"),
    "stability_bound_nan": ('"stability": {"max_overlap": {"quantity": "thermo.ke", "upper": NaN}}',
                            "$.runs[1].stability.max_overlap.upper", "NaN"),
    "sweep_values_text": ('"sweep": {"variable": "X", "values": "ab", "error": {"quantity": "thermo.ke"}}',
                          "$.runs[1].sweep.values", "list"),
    "sweep_with_nan": ('"sweep": {"variable": "X", "values": [1, 2], "with": {"Y": [NaN, 2]}, '
                       '"error": {"quantity": "thermo.ke"}}', "$.runs[1].sweep.with.Y[0]", "NaN"),
    "thermo_columns_list": ('"thermo_columns": ["KinEng"]', "$.runs[1].thermo_columns", "object"),
    "mpi_options_objects": ('"type": "mpi/custom", "mpi_options": ["-np", {"n": 2}]',
                            "$.runs[1].mpi_options[1]", "string"),
    "vtk_density_text": ('"vtk": {"density": "heavy"}', "$.runs[1].vtk.density", "number"),
    "script_per_engine_number": ('"script": {"dem": 3}', "$.runs[1].script.dem", "file name"),
    "data_series_text": ('"data": {"series": "x"}', "$.runs[1].data.series", "list"),
}


@pytest.mark.parametrize("case", sorted(BAD_ENTRIES))
def test_a_broken_run_config_entry_fails_alone_with_file_and_json_path(shared, case):
    fields, where, text = BAD_ENTRIES[case]
    entry = '{"name": "bad", "script": "scene.json", ' + fields + "}"
    if fields.startswith('"script"'):
        entry = '{"name": "bad", ' + fields + "}"
    config = shared.write_case(case, GOOD + ", " + entry)
    result = shared.harness("run", "-k", f"cases/{case}/")
    assert_clean(result)
    assert result.returncode == 1                  # a broken input file is a failure of the command
    runs = shared.runs()
    assert runs[("t", f"cases/{case}", "good")]["state"] == "post_processed"   # the rest ran
    bad = runs[("t", f"cases/{case}", "bad")]
    assert (bad["state"], bad["reason"]) == ("failed", "config")
    assert f"{config}: {where}: " in bad["message"], bad["message"]
    assert text in bad["message"].split(f"{where}: ", 1)[1], bad["message"]   # not in the file's name
    problem_lines = [line for line in result.stderr.splitlines() if f"{config}: {where}: " in line]
    assert problem_lines, result.stderr                                          # told on the terminal too


#: a value of every JSON kind (and the numbers JSON has not) for every field of a run configuration
FUZZ_VALUES = ['null', 'true', '0', '-1', '1.5', '1e400', 'NaN', '-Infinity', '"x"', '""', '"../x"', '"a b"',
               '[]', '[1]', '["a"]', '[null]', '{}', '{"a": 1}', '{"a": NaN}', '{"a": {"b": []}}', '[{"a": "b"}]']
FUZZ_BASES = [
    '{"name": "r", "script": "scene.json"}',
    '{"name": "r", "type": "mpi", "nprocs": 2, "script": "scene.json", '
    '"sweep": {"variable": "X", "values": [1, 2], "error": {"quantity": "thermo.ke"}}}',
    '{"name": "r", "type": "mpi/custom", "script": "scene.json", '
    '"expectations": [{"quantity": "thermo.ke", "upper": 1}], '
    '"stability": {"max_overlap": {"quantity": "thermo.ke", "upper": 1}}}',
]


def test_any_value_in_any_field_gives_runs_the_planner_and_the_store_can_take(tmp_path):
    """Discovery never raises on a run.config, and what it hands on is what the planner (harness.execution.scheduler
    reads ``variables`` and ``thermo_columns`` as objects, ``timeout`` as a number) and the store (strict
    JSON, no NaN) can take; every problem is one line."""
    from harness.adapters import get_adapter
    from harness.config import known_fields
    from harness.config.runconfig import RunConfigEntry
    from harness.config.testcases import load_testcase

    (tmp_path / "scene.json").write_text("[]")
    failures = []
    for key in sorted(known_fields(RunConfigEntry)) + ["colour"]:
        for value in FUZZ_VALUES:
            for base in FUZZ_BASES:
                entry = base[:-1] + f', "{key}": {value}' + "}"
                (tmp_path / "run.config").write_text(
                    '{"runs": [' + entry + ', {"name": "other", "script": "scene.json", "depends_on": "r"}]}')
                try:
                    spec = load_testcase(tmp_path, "case", get_adapter("dem"))
                    for run in spec.runs:
                        json.dumps(run.config, allow_nan=False)
                        assert isinstance(run.config.get("variables", {}), dict)
                        assert isinstance(run.config.get("thermo_columns", {}), dict)
                        assert run.timeout > 0
                        assert all("\n" not in problem for problem in run.problems)
                except Exception as exc:  # noqa: BLE001 - collected, so one run shows every failing input
                    failures.append(f"{key}={value} in {base[:40]}: {type(exc).__name__}: {exc}")
    assert not failures, "\n".join(failures[:20]) + f"\n({len(failures)} in all)"


def test_non_finite_numbers_are_refused_with_line_and_column(tmp_path):
    from harness.config.jsonfile import load_json

    path = tmp_path / "run.config"
    path.write_text('{"runs": [\n  {"name": "a", "timeout": NaN}\n]}\n')
    with pytest.raises(UserError) as info:
        load_json(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and "line 2 column 28" in message and "NaN" in message
    assert "\n" not in message


def test_a_nan_in_a_finished_runs_file_does_not_lose_the_earlier_result(shared):
    """The measured fault: a NaN timeout aborted the whole ``harness run`` with an IntegrityError after a
    run had finished, and that result never reached the store."""
    config = shared.write_case("finished_then_nan", GOOD + ', {"name": "later", "script": "scene.json", '
                               '"depends_on": "good", "timeout": NaN}')
    result = shared.harness("run", "-k", "cases/finished_then_nan/")
    assert_clean(result)
    runs = shared.runs()
    assert runs[("t", "cases/finished_then_nan", "good")]["state"] == "post_processed"
    later = runs[("t", "cases/finished_then_nan", "later")]
    assert later["reason"] == "config" and f"{config}: $.runs[1].timeout: " in later["message"]


def test_json_paths_count_entries_as_written_when_a_sweep_comes_first(tmp_path):
    """A sweep expands into several runs; the JSON path of a later entry is still its index in the file."""
    from harness.config.jsonfile import load_json
    from harness.config.testcases import parse_run_config

    case = tmp_path / "case"
    case.mkdir()
    (case / "scene.json").write_text("[]")
    path = case / "run.config"
    path.write_text('{"runs": [{"name": "s", "script": "scene.json", "sweep": {"variable": "DT", '
                    '"values": [1, 2, 3], "error": {"quantity": "thermo.ke"}}}, '
                    '{"name": "bad", "script": "scene.json", "timeout": "ten"}]}')
    entries, _ = parse_run_config(load_json(path), path, "dem")
    bad = next(e for e in entries if e.name == "bad")
    assert bad.problems and bad.problems[0].startswith(f"{path}: $.runs[1].timeout: ")


#: target files that must be refused with a one-line problem naming the file and the JSON path
BAD_TARGETS = {
    "launcher_empty": ('"mpi_launcher": []', "$.mpi_launcher", "at least"),
    "make_variables_nested": ('"make_target": "x", "generated_executable": "x", "make_variables": {"A": {"B": 1}}',
                              "$.make_variables.A", "string or number"),
    "make_variable_nan": ('"make_target": "x", "generated_executable": "x", "make_variables": {"A": NaN}',
                          "$.make_variables.A", "NaN"),
    "make_jobs_1e400": ('"make_jobs": 1e400', "$.make_jobs", "1e400"),
    "thermo_columns_list": ('"thermo_columns": ["ke"]', "$.thermo_columns", "object"),
    "testcases_parent": ('"testcases": ["../elsewhere"]', "$.testcases[0]", "'..'"),
    "reference_path": ('"reference": "../other"', "$.reference", "not a safe name"),
    "revision_number": ('"revision": 3', "$.revision", "string"),
}


@pytest.mark.parametrize("case", sorted(BAD_TARGETS))
def test_a_broken_target_file_is_one_problem_with_file_and_json_path(tmp_path, case):
    from harness.config.targets import load_targets

    fields, where, text = BAD_TARGETS[case]
    folder = tmp_path / "targets"
    folder.mkdir()
    (folder / "ok.json").write_text("{}")
    path = folder / f"{case}.json"
    path.write_text("{" + fields + "}")
    targets, problems = load_targets(folder)
    assert sorted(targets) == ["ok"]
    mine = [p for p in problems if p.startswith(f"{path}: {where}: ")]
    assert mine and text in mine[0].split(f"{where}: ", 1)[1] and "\n" not in mine[0], problems


def test_a_broken_target_named_on_the_command_line_is_a_one_line_error(project):
    project.write_target("t", '{"repository": "%s", "testcases": ["%s"], "make_jobs": NaN}'
                         % (project.repo, project.cases))
    line = one_error_line(project.harness("run", "t"))
    assert f"{project.targets / 't.json'}: $.make_jobs: " in line


def test_an_empty_mpi_launcher_does_not_reach_the_runs(project):
    """Measured before: IndexError in the planner, a traceback, for a target with ``"mpi_launcher": []``."""
    project.write_target("t", mpi_launcher=[])
    project.write_case("mpi", GOOD + ', {"name": "ranks", "type": "mpi", "nprocs": 2, "script": "scene.json"}')
    line = one_error_line(project.harness("run", "t"))
    assert f"{project.targets / 't.json'}: $.mpi_launcher: " in line


# ------------------------------------------------------------------------------------------------ 2. names

UNSAFE_RUN_NAMES = {"absolute": None, "parent": "..", "empty": "", "climbing": "x/../../../victim",
                    "space": "a b", "reserved": "post", "pseudo_run": "run.config"}


@pytest.mark.parametrize("case", sorted(UNSAFE_RUN_NAMES))
def test_unsafe_run_names_are_refused_up_front_and_nothing_outside_is_touched(shared, case):
    victim = shared.root / f"victim_{case}"
    (victim / "precious").mkdir(parents=True)
    (victim / "precious" / "data.txt").write_text("keep me")
    name = UNSAFE_RUN_NAMES[case] if UNSAFE_RUN_NAMES[case] is not None else str(victim)
    config = shared.write_case(f"names_{case}", GOOD + ", " + json.dumps({"name": name, "script": "scene.json"}))
    result = shared.harness("run", "-k", f"cases/names_{case}/")
    assert_clean(result)
    assert result.returncode == 1
    assert (victim / "precious" / "data.txt").read_text() == "keep me"
    runs = {key[2]: row for key, row in shared.runs().items() if key[1] == f"cases/names_{case}"}
    assert runs["good"]["state"] == "post_processed"
    assert name not in runs                       # the unsafe name never becomes a run (nor a folder)
    bad = runs["runs[1]"]
    assert bad["reason"] == "config" and f"{config}: $.runs[1].name: " in bad["message"], bad["message"]


def test_a_run_named_after_a_folder_outside_the_workspace_through_the_cli(project):
    """The brief's measured case: a run named ``/some/folder`` made ``harness run`` delete that folder."""
    victim = project.root / "victim"
    victim.mkdir()
    (victim / "keep.txt").write_text("keep")
    config = project.write_case("case", json.dumps({"name": str(victim), "script": "scene.json"}))
    result = project.harness("run")
    assert_clean(result)
    assert result.returncode == 1
    assert (victim / "keep.txt").read_text() == "keep"
    assert f"{config}: $.runs[0].name: " in result.stderr


def test_unsafe_target_file_names_are_problems(tmp_path):
    from harness.config.targets import load_targets, select_targets

    folder = tmp_path / "targets"
    folder.mkdir()
    for name in ("good", "a b", ".", "-x"):
        (folder / f"{name}.json").write_text("{}")
    targets, problems = load_targets(folder)
    assert sorted(targets) == ["good"]
    for name in ("a b", ".", "-x"):
        assert any(p.startswith(f"{folder / (name + '.json')}: ") and "name" in p for p in problems), problems
    with pytest.raises(UserError, match="not a safe name"):
        select_targets([str(folder / "a b.json")], folder)


def test_a_test_case_folder_with_an_unsafe_name_is_reported_and_skipped(project):
    project.write_case("fine", GOOD)
    project.write_case("has space", GOOD)
    project.write_case("inner", GOOD, folder=project.cases / "-dash")
    result = project.harness("run")
    assert_clean(result)
    assert result.returncode == 1
    assert project.runs()[("t", "cases/fine", "good")]["state"] == "post_processed"
    assert not [key for key in project.runs() if "space" in key[1] or "dash" in key[1]]
    assert f"{project.cases / 'has space'}: " in result.stderr
    assert f"{project.cases / '-dash'}: " in result.stderr


def test_a_run_config_in_a_reserved_folder_is_reported_not_silently_ignored(project):
    project.write_case("fine", GOOD)
    project.write_case("post", GOOD)                        # at the top of the test case tree
    project.write_case("scripts", GOOD, folder=project.cases / "fine")   # inside a test case
    result = project.harness("run")
    assert_clean(result)
    assert result.returncode == 1
    assert list(project.runs()) == [("t", "cases/fine", "good")]
    for folder in (project.cases / "post", project.cases / "fine" / "scripts"):
        assert f"{folder / 'run.config'}: " in result.stderr and "reserved" in result.stderr


# ----------------------------------------------------------------------------------- 3. reference cycles

def _targets(folder: Path, references: dict) -> None:
    folder.mkdir()
    for name, reference in references.items():
        (folder / f"{name}.json").write_text(json.dumps({"reference": reference} if reference else {}))


@pytest.mark.parametrize("references,cycle", [
    ({"a": "b", "b": "a"}, ["a", "b"]),
    ({"a": "b", "b": "c", "c": "a"}, ["a", "b", "c"]),
    ({"a": "b", "b": "c", "c": "d", "d": "b", "e": None}, ["b", "c", "d"]),
])
def test_reference_cycles_are_problems_of_every_target_in_them(tmp_path, references, cycle):
    from harness.config.targets import load_targets

    folder = tmp_path / "targets"
    _targets(folder, references)
    targets, problems = load_targets(folder)
    for name in cycle:
        mine = [p for p in problems if p.startswith(f"{folder / (name + '.json')}: $.reference: ")]
        assert mine and "cycle" in mine[0] and "\n" not in mine[0], problems
        assert name not in targets
    if "e" in references:
        assert "e" in targets                        # a target outside the cycle is unaffected
        assert any(p.startswith(f"{folder / 'a.json'}: $.reference: ") for p in problems)   # leads into it


def test_reference_of_refuses_a_cycle_even_for_a_target_loaded_from_its_file(tmp_path):
    from harness.config.targets import load_target_file, reference_of

    folder = tmp_path / "targets"
    _targets(folder, {"a": "b", "b": "a"})
    with pytest.raises(UserError, match=r"\$\.reference: .*cycle"):
        reference_of(load_target_file(folder / "a.json"))


def test_harness_run_of_a_target_in_a_reference_cycle_is_a_one_line_error(project):
    project.write_target("a", reference="b")
    project.write_target("b", reference="a")
    project.write_case("case", GOOD)
    line = one_error_line(project.harness("run", "a"))
    assert "$.reference: " in line and "cycle" in line


# ------------------------------------------------------------------------- 4. post scripts' process group

def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")             # a zombie waiting for its parent to reap it is gone


def test_a_post_script_that_times_out_leaves_no_process_behind(project):
    pid_file = project.root / "grandchild.pid"
    case = project.cases / "spawner"
    project.write_case("spawner", json.dumps({"name": "run", "script": "scene.json", "timeout": 5,
                                              "post_scripts": ["spawn.sh"]}))
    script = case / "spawn.sh"
    script.write_text(f"#!/bin/sh\nsleep 300 &\necho $! > {pid_file}\nsleep 100\n")
    script.chmod(0o755)
    started = time.monotonic()
    result = project.harness("run")
    pid = int(pid_file.read_text())
    try:
        assert_clean(result)
        assert time.monotonic() - started < 60
        row = project.runs()[("t", "cases/spawner", "run")]
        assert (row["state"], row["reason"]) == ("failed", "post_script")
        assert "timed out" in row["message"]
        deadline = time.monotonic() + 5
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(pid), f"the post script's child {pid} outlived the timeout"
    finally:
        if _alive(pid):
            os.kill(pid, 9)  # this test's own grandchild, by its pid


def test_a_post_script_leaving_a_background_child_after_success_does_not_hang_the_run(project):
    """A post script that exits 0 but leaves ``sleep`` holding its stderr must not make the harness wait."""
    pid_file = project.root / "left.pid"
    case = project.cases / "leaver"
    project.write_case("leaver", json.dumps({"name": "run", "script": "scene.json", "timeout": 60,
                                             "post_scripts": ["leave.sh"]}))
    script = case / "leave.sh"
    script.write_text(f"#!/bin/sh\nsleep 300 &\necho $! > {pid_file}\nexit 0\n")
    script.chmod(0o755)
    started = time.monotonic()
    result = project.harness("run")
    pid = int(pid_file.read_text())
    try:
        assert_clean(result)
        assert time.monotonic() - started < 30
        assert project.runs()[("t", "cases/leaver", "run")]["state"] == "post_processed"
        assert not _alive(pid)
    finally:
        if _alive(pid):
            os.kill(pid, 9)


# ---------------------------------------------------------------- 5. a workspace or store that cannot be written

def test_a_workspace_that_is_a_file_is_a_one_line_error(project):
    home = project.root / "afile"
    home.write_text("not a folder")
    line = one_error_line(project.harness("run", home=home))
    assert str(home) in line


def test_a_workspace_that_cannot_be_created_is_a_one_line_error(project):
    line = one_error_line(project.harness("run", home=Path("/proc/harness-home")))
    assert "/proc/harness-home" in line


def test_junit_to_a_full_device_is_a_one_line_error(project):
    project.write_case("case", GOOD)
    assert project.harness("run").returncode == 0
    line = one_error_line(project.harness("check", "--junit", "/dev/full"))
    assert "/dev/full" in line


def test_a_run_folder_that_cannot_be_written_fails_that_run_and_keeps_earlier_records(project):
    project.write_case("first", GOOD)
    assert project.harness("run").returncode == 0
    # the run folders of target t cannot be created: a file stands where their folder must be
    shutil.rmtree(project.home / "runs")
    (project.home / "runs").write_text("in the way")
    project.write_case("second", GOOD)
    result = project.harness("run")
    assert_clean(result)
    assert result.returncode == 1
    runs = project.runs()
    assert runs[("t", "cases/first", "good")]["state"] == "post_processed"
    second = runs[("t", "cases/second", "good")]
    assert second["state"] == "failed" and "cannot prepare run folder" in second["message"]
    assert "\n" not in second["message"]


def _mount_namespace_works(tmp: Path) -> bool:
    if shutil.which("unshare") is None:
        return False
    probe = tmp / "probe"
    probe.mkdir()
    result = subprocess.run(["unshare", "-m", "sh", "-c", f"mount -t tmpfs -o size=1m tmpfs {probe}"],
                            capture_output=True)
    return result.returncode == 0


def _in_mount_namespace(project: Project, script: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("HARNESS_TARGETS", "HARNESS_DATABASE_URL")}
    return subprocess.run(["unshare", "-m", "sh", "-c", script], cwd=REPO, env=env, capture_output=True,
                          text=True, timeout=300)


def _cli(project: Project, home: Path, *args: str) -> str:
    return (f"HARNESS_HOME={home} {sys.executable} -m harness.cli --home {home} --targets {project.targets} "
            f"--machine m {' '.join(args)}")


@pytest.mark.parametrize("what", ["database", "workspace"])
def test_a_read_only_store_is_a_one_line_error_and_keeps_its_records(project, tmp_path, what):
    """As root, chmod does not stop writes: a read-only bind mount (in a private mount namespace) does."""
    if not _mount_namespace_works(tmp_path):
        pytest.skip("needs unshare -m and mount (root in a container that allows it)")
    project.write_case("case", GOOD)
    assert project.harness("run").returncode == 0
    before = project.runs()
    read_only = project.home / "harness.sqlite3" if what == "database" else project.home
    result = _in_mount_namespace(project, f"mount --bind {read_only} {read_only} && "
                                          f"mount -o remount,ro,bind {read_only} && "
                                          + _cli(project, project.home, "run", "--all"))
    line = one_error_line(result)
    if what == "database":
        assert line.startswith(f"harness: error: store {project.home / 'harness.sqlite3'}: "), line
    else:  # whichever file of the workspace is written first (a lock, the store) is named
        assert line.startswith(f"harness: error: {project.home}") or \
            line.startswith(f"harness: error: store {project.home}"), line
        assert "read-only" in line.lower() or "readonly" in line.lower(), line
    assert project.runs() == before


def test_a_full_disk_is_a_one_line_error_and_keeps_the_records(project, tmp_path):
    if not _mount_namespace_works(tmp_path):
        pytest.skip("needs unshare -m and mount (root in a container that allows it)")
    project.write_case("case", GOOD)
    disk = project.root / "disk"
    disk.mkdir()
    home = disk / "home"
    saved = project.root / "saved"
    saved.mkdir()
    # everything that needs the small file system happens inside the namespace; the store is copied out
    script = "; ".join([
        f"mount -t tmpfs -o size=8m tmpfs {disk} || exit 90",
        _cli(project, home, "run") + " > /dev/null 2>&1 || exit 91",
        f"dd if=/dev/zero of={disk}/filler bs=64k > /dev/null 2>&1",
        _cli(project, home, "run", "--all", "-k", "nothing-matches-but-the-store-is-opened") + " ; echo RC=$?",
        _cli(project, home, "run", "--all") + " ; echo RC=$?",
        f"rm {disk}/filler",
        f"cp {home}/harness.sqlite3* {saved}/",
    ])
    result = _in_mount_namespace(project, script)
    assert "RC=" in result.stdout, result.stdout + result.stderr
    assert_clean(result)
    codes = [line for line in result.stdout.splitlines() if line.startswith("RC=")]
    assert codes and all(code != "RC=0" for code in codes), result.stdout
    errors = [line for line in result.stderr.splitlines() if line.startswith("harness: error:")]
    assert len(errors) == len(codes), result.stderr
    assert all(line.startswith(f"harness: error: store {home / 'harness.sqlite3'}: ") for line in errors), errors
    assert stored_runs(saved / "harness.sqlite3")[("t", "cases/case", "good")]["state"] == "post_processed"
