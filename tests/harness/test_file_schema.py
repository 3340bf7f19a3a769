"""The declarative schema of the harness' files (harness/config): exported as JSON Schema, every file of the
repository valid against it (checked with the jsonschema library, independently of pydantic), and
docs/run-config.md generated from it."""
import json
import subprocess
import sys
from pathlib import Path

import jsonschema
import pytest

from harness.config.export import KINDS, json_schema, markdown

ROOT = Path(__file__).resolve().parents[2]


def _validator(kind):
    schema = json_schema(kind)
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


@pytest.mark.parametrize("kind, pattern", [("run.config", "testcases/**/run.config"), ("target", "targets/*.json")])
def test_every_file_of_the_repository_validates_against_the_exported_schema(kind, pattern):
    validator = _validator(kind)
    files = sorted(ROOT.glob(pattern))
    assert len(files) >= (30 if kind == "run.config" else 10)
    problems = [f"{path.relative_to(ROOT)}: {list(error.absolute_path)}: {error.message}"
                for path in files for error in validator.iter_errors(json.loads(path.read_text()))]
    assert problems == []


@pytest.mark.parametrize("kind, document", [
    ("run.config", {"runs": [{"name": "a", "script": "s.json", "timeout": "ten"}]}),
    ("run.config", {"runs": [{"name": "a", "script": "s.json", "type": "mpi", "nprocs": 0}]}),
    ("run.config", {"runs": [{"name": "a/b", "script": "s.json"}]}),
    ("run.config", {"runs": [{"name": "a", "script": "s.json", "colour": "red"}]}),
    ("run.config", {"runs": [{"name": "a", "script": "s.json", "description": None}]}),
    ("run.config", {"runs": [{"name": "a", "script": "s.json",
                              "expectations": [{"quantity": "thermo.ke", "at": "last", "upper": 1}]}]}),
    ("run.config", {"runs": [{"name": "a", "script": "s.json",
                              "sweep": {"variable": "DT", "values": [1], "error": {"quantity": "thermo.ke"}}}]}),
    ("target", {"recipe": "scons"}),
    ("target", {"mpi_launcher": []}),
    ("target", {"commit_url": "https://example.org/commit"}),
    ("adapter", {"command": ["{executable}"], "thermo": {"csv": "a.csv"}}),
    ("record", {"machine": "m", "target": "t", "testcase": "c", "run": "r", "state": "passed"}),
])
def test_the_schema_refuses_what_the_readers_refuse(kind, document):
    assert list(_validator(kind).iter_errors(document))


def test_a_valid_adapter_file_and_record_validate():
    adapter = {"command": ["{executable}", "{script}"], "thermo": {"log_pattern": "(?P<step>\\d+)"},
               "timing": {"total": "took (\\S+)"}}
    assert list(_validator("adapter").iter_errors(adapter)) == []
    record = {"machine": "m", "target": "t", "testcase": "c", "run": "r", "state": "failed",
              "failure_reason": "timeout", "exit_code": None, "a_field_of_a_newer_harness": 1}
    assert list(_validator("record").iter_errors(record)) == []


def test_docs_run_config_is_the_generated_reference():
    """docs/run-config.md is generated: regenerate it with ``harness schema run.config --markdown``."""
    assert (ROOT / "docs" / "run-config.md").read_text() == markdown()


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_the_committed_schemas_are_the_exported_ones(kind):
    """docs/schemas/KIND.json, for editors to point at without running the harness, is what
    ``harness schema KIND`` prints (regenerate with ``harness schema KIND > docs/schemas/KIND.json``)."""
    assert json.loads((ROOT / "docs" / "schemas" / f"{kind}.json").read_text()) == json_schema(kind)


def test_harness_schema_prints_each_kind():
    for kind in KINDS:
        out = subprocess.run([sys.executable, "-m", "harness.cli", "schema", kind], capture_output=True,
                             text=True, cwd=ROOT, check=True).stdout
        jsonschema.Draft202012Validator.check_schema(json.loads(out))
    bad = subprocess.run([sys.executable, "-m", "harness.cli", "schema", "target", "--markdown"],
                         capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode != 0 and "only for run.config" in bad.stderr and "\n" == bad.stderr[-1]


def test_problems_are_values_with_a_json_path(tmp_path):
    """Each problem is a (JSON path, message) value; what is left out of a broken entry, and which name it
    is recorded under, follow from the paths, never from the text of a message."""
    from harness.config.jsonfile import Problem
    from harness.config.testcases import parse_run_config

    (tmp_path / "scene.json").write_text("[]")
    path = tmp_path / "run.config"
    data = {"runs": [{"name": "ok", "script": "scene.json", "timeout": 5},
                     {"name": "bad", "script": "scene.json", "timeout": "ten", "variables": {"X": None},
                      "vtk": {"density": 2500}},
                     {"name": "a b", "script": "scene.json"}]}
    entries, _ = parse_run_config(data, path, "dem")
    ok, bad, unnamed = entries
    assert ok.found == [] and ok.spec.timeout == 5.0 and ok.timeout == 5.0
    assert bad.found == [Problem(("runs", 1, "variables", "X"), "must be a string or number, got null"),
                         Problem(("runs", 1, "timeout"), 'must be a number of seconds, got string "ten"')]
    assert bad.spec is None and set(bad.config) == {"name", "script", "vtk"}   # the broken fields left out
    assert bad.problems[1] == f'{path}: $.runs[1].timeout: must be a number of seconds, got string "ten"'
    assert unnamed.name == "runs[2]" and unnamed.found[0].path == ("runs", 2, "name")


def test_run_spec_and_record_survive_pickling_as_dask_ships_them():
    import pickle

    from harness.store.runrecord import RunRecord, RunSpec

    spec = RunSpec(machine="m", target="t", target_definition={}, build={"commit": "c"}, testcase="cases/a",
                   run="r", testcase_hash="h", config={"name": "r"}, adapter="dem", thermo_columns={},
                   environment={}, workspace="/w", folder="/w/r", source_folder="/c", files=["scene.json"],
                   timeout=5.0, command=["dem", "scene.json"])
    assert pickle.loads(pickle.dumps(spec)) == spec
    record = spec.record().fail("timeout", "timed out after 5 s")
    again = pickle.loads(pickle.dumps(record))
    assert again == record and again.failed and again.to_dict()["failure_reason"] == "timeout"
    assert list(again.to_dict())[:5] == ["machine", "target", "testcase", "run", "state"]
