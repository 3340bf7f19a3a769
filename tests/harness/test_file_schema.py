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


def test_harness_schema_prints_each_kind():
    for kind in KINDS:
        out = subprocess.run([sys.executable, "-m", "harness.cli", "schema", kind], capture_output=True,
                             text=True, cwd=ROOT, check=True).stdout
        jsonschema.Draft202012Validator.check_schema(json.loads(out))
    bad = subprocess.run([sys.executable, "-m", "harness.cli", "schema", "target", "--markdown"],
                         capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode != 0 and "only for run.config" in bad.stderr and "\n" == bad.stderr[-1]
