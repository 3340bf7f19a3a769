"""Target definitions and run.config files: validation messages name the file, the JSON path and the problem."""
import json
from pathlib import Path

import pytest

from harness.adapters import get_adapter
from harness.adapters.base import UserError
from harness.config.jsonfile import load_json
from harness.config.targets import (
    WORKING_TREE,
    load_target_file,
    load_targets,
    select_targets,
)
from harness.config.testcases import (
    CONFIG_RUN,
    load_testcase,
    matches,
    parse_run_config,
)


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_malformed_json_reports_line_and_column(tmp_path):
    path = write(tmp_path / "targets" / "broken.json", '{\n  "revision": "HEAD",\n  "recipe" "dem"\n}\n')
    with pytest.raises(UserError, match=r"broken.json: invalid JSON at line 3 column 12"):
        load_json(path)


def test_target_fields_are_validated_with_json_paths(tmp_path):
    path = write(tmp_path / "targets" / "t.json", json.dumps(
        {"recipe": "scons", "testcases": "cases", "make_variables": {"CC": ["gcc"]}, "colour": "red"}))
    with pytest.raises(UserError) as info:
        load_target_file(path)
    message = str(info.value)
    assert "t.json: $.recipe: unknown recipe 'scons'" in message
    assert "$.testcases: must be a list of folders" in message
    assert "$.make_variables.CC: must be a string or number" in message
    assert "$.colour: unknown field" in message
    assert "\n" not in message


def test_make_and_system_recipes_need_their_fields(tmp_path):
    with pytest.raises(UserError, match=r"\$\.generated_executable: required for the make recipe"):
        load_target_file(write(tmp_path / "targets" / "m.json", '{"make_target": "serial"}'))
    with pytest.raises(UserError, match=r"\$\.executable: required"):
        load_target_file(write(tmp_path / "targets" / "s.json", '{"recipe": "system"}'))


def test_defaults_and_unknown_reference(tmp_path):
    write(tmp_path / "targets" / "a.json", '{"reference": "b"}')
    write(tmp_path / "targets" / "b.json", '{"revision": "v1"}')
    write(tmp_path / "targets" / "c.json", '{"reference": "nope"}')
    write(tmp_path / "targets" / "d.json", '{oops')
    targets, problems = load_targets(tmp_path / "targets")
    assert sorted(targets) == ["a", "b"]
    assert targets["a"].testcases_revision == WORKING_TREE          # HEAD: the working tree by default
    assert targets["b"].testcases_revision == "v1"
    assert targets["a"].recipe == "dem" and targets["a"].source_folder == "engine"
    assert any("c.json: $.reference: unknown target 'nope'" in p for p in problems)
    assert any("d.json: invalid JSON at line 1" in p for p in problems)
    with pytest.raises(UserError, match="unknown target 'zz'"):
        select_targets(["zz"], tmp_path / "targets")
    with pytest.raises(UserError, match="unknown target 'nope'"):
        select_targets(["c"], tmp_path / "targets")


def test_a_test_case_repository_that_is_none_names_the_target_file_and_field(tmp_path):
    from harness.config.testcases import testcase_root

    write(tmp_path / "targets" / "elsewhere.json", '{"testcases_repository": "no-such-checkout", "testcases": ["a"]}')
    targets, problems = load_targets(tmp_path / "targets")
    assert not problems
    with pytest.raises(UserError) as raised:
        testcase_root(targets["elsewhere"])
    assert str(raised.value).startswith(f"{tmp_path / 'targets' / 'elsewhere.json'}: $.testcases_repository: "
                                        f"repository {tmp_path / 'no-such-checkout'}: not a git repository")


def test_shipped_targets_are_valid():
    targets, problems = load_targets(Path(__file__).parents[2] / "targets")
    assert not [p for p in problems if "dem" in p]
    assert targets["dem"].reference == "dem-reference"
    assert len(targets["dem-reference"].revision) == 40


def _config(folder: Path, data) -> Path:
    return write(folder / "run.config", json.dumps(data) if not isinstance(data, str) else data)


def test_run_config_validation(tmp_path):
    case = tmp_path / "case"
    write(case / "scene.json", "[]")
    path = _config(case, {"runs": [
        {"name": "ok", "script": "scene.json", "variables": {"N": 4}},
        {"name": "noscript", "script": "missing.json"},
        {"name": "mpi", "type": "mpi", "script": "scene.json"},
        {"name": "bad", "type": "gpu", "script": "scene.json", "timeout": -1, "nprocs": "4",
         "consistency": {"ke": {"epsilon": "x", "tolerance": 1}}},
    ]})
    entries, file_problems = parse_run_config(load_json(path), path, "dem")
    assert not file_problems
    by_name = {e.name: e for e in entries}
    assert by_name["ok"].problems == [] and by_name["ok"].script == "scene.json"
    assert by_name["noscript"].problems == [f"{path}: $.runs[1].script: script 'missing.json' not found in {case}"]
    assert "$.runs[2].nprocs: required for type mpi" in by_name["mpi"].problems[0]
    bad = " ".join(by_name["bad"].problems)
    for expected in ("$.runs[3].type: unknown run type 'gpu'", "$.runs[3].timeout: must be positive",
                     "$.runs[3].consistency.ke.epsilon: must be a number",
                     "$.runs[3].consistency.ke.tolerance: unknown field"):
        assert expected in bad


def test_dependency_cycle_and_unknown_dependency(tmp_path):
    case = tmp_path / "case"
    write(case / "s.json", "[]")
    path = _config(case, {"runs": [{"name": "a", "script": "s.json", "depends_on": "b"},
                                   {"name": "b", "script": "s.json", "depends_on": "a"},
                                   {"name": "c", "script": "s.json", "depends_on": "zz"}]})
    entries, problems = parse_run_config(load_json(path), path, "dem")
    text = " ".join(problems)
    assert "$.runs[2].depends_on: unknown run 'zz'" in text
    assert "dependency cycle: a -> b -> a" in text
    assert all(e.problems for e in entries)


def test_script_per_adapter_selects_or_skips_runs(tmp_path):
    case = tmp_path / "case"
    write(case / "scene.json", "[]")
    write(case / "in.scene", "")
    path = _config(case, {"runs": [{"name": "both", "script": {"dem": "scene.json", "liggghts": "in.scene"}},
                                   {"name": "only_liggghts", "script": {"liggghts": "in.scene"}}]})
    dem_entries, _ = parse_run_config(load_json(path), path, "dem")
    assert [(e.name, e.script) for e in dem_entries] == [("both", "scene.json")]
    lig_entries, _ = parse_run_config(load_json(path), path, "liggghts")
    assert [(e.name, e.script) for e in lig_entries] == [("both", "in.scene"), ("only_liggghts", "in.scene")]


def test_broken_run_config_becomes_one_config_run(tmp_path):
    case = tmp_path / "case"
    _config(case, '{"runs": [ {"name": "a",, } ]}')
    spec = load_testcase(case, "case", get_adapter("dem"))
    assert [e.name for e in spec.runs] == [CONFIG_RUN]
    assert "invalid JSON at line 1 column 25" in spec.runs[0].problems[0]
    assert load_testcase(tmp_path, "x", get_adapter("dem")) is None    # no run.config: not a dem test case


def test_k_pattern_matching():
    assert matches(None, "a/b", "run")
    assert matches("b/ru", "a/b", "run")
    assert not matches("zz", "a/b", "run")
    assert matches("a/*/serial", "a/x", "serial")
    assert matches("a/*", "a/b", "run")
    assert not matches("c/*", "a/b", "run")


def test_mpi_launcher_prefix(tmp_path, monkeypatch):
    from harness.adapters import base
    from harness.config.targets import parse_target
    from harness.execution import planning

    target = parse_target("t", {"mpi_launcher": ["mpiexec"]}, tmp_path / "targets" / "t.json")
    monkeypatch.setattr(base, "is_open_mpi", lambda launcher: False)
    assert planning.mpi_prefix(target, {"type": "serial"}) is None
    assert planning.mpi_prefix(target, {"type": "mpi", "nprocs": 4}) == ["mpiexec", "-np", "4"]
    assert planning.mpi_prefix(target, {"type": "mpi/custom", "mpi_options": "-np 2 --bind-to core"}) == \
        ["mpiexec", "-np", "2", "--bind-to", "core"]
    monkeypatch.setattr(base, "is_open_mpi", lambda launcher: True)
    monkeypatch.setattr(base.os, "geteuid", lambda: 0)
    monkeypatch.setattr(base.os, "cpu_count", lambda: 2)
    assert planning.mpi_prefix(target, {"type": "mpi", "nprocs": 4}) == \
        ["mpiexec", "--allow-run-as-root", "--oversubscribe", "-np", "4"]
    monkeypatch.setattr(base.os, "geteuid", lambda: 1000)
    assert planning.mpi_prefix(target, {"type": "mpi", "nprocs": 2}) == ["mpiexec", "-np", "2"]
