"""A newcomer's path through the real CLI: ``harness new testcase``, ``harness validate`` (nothing built or
run), ``harness run --testcases FOLDER`` for a folder outside the project, and the README's "your first test
case" (write it, run it, break it) with the bundled engine."""
import json
from pathlib import Path

import pytest
from harness_support import commit_files, fake_engine_source, git_repo

from harness.cli import main
from harness.execution.workspace import PROJECT_ROOT


def harness(*args) -> int:
    return main(["--machine", "m1", *args])


def test_validate_checks_every_target_and_run_config_and_names_the_field(tmp_path, capsys, store):
    targets = tmp_path / "targets"
    targets.mkdir()
    cases = tmp_path / "cases"
    (cases / "good").mkdir(parents=True)
    (cases / "good" / "scene.json").write_text("[]")
    (cases / "good" / "run.config").write_text(json.dumps({"runs": [{"name": "a", "script": "scene.json"}]}))
    (cases / "typo").mkdir()
    (cases / "typo" / "scene.json").write_text("[]")
    (cases / "typo" / "run.config").write_text(json.dumps({"runs": [
        {"name": "a", "script": "scene.json", "expectations": [{"quantity": "thermo.ke", "rel_tolerance": 1}]}]}))
    (targets / "mine.json").write_text(json.dumps({"recipe": "system", "executable": "/bin/true",
                                                   "testcases": [str(cases)]}))
    (targets / "broken.json").write_text(json.dumps({"revision": "v1", "colour": "red"}))
    builds = Path(store / "home" / "builds")
    assert main(["--targets", str(targets), "validate"]) == 1
    out, err = capsys.readouterr()
    assert "broken.json: $.colour: unknown field" in err
    assert f"{cases / 'typo' / 'run.config'}: $.runs[0].expectations[0]: unknown field(s) rel_tolerance" in err
    assert "good" not in err
    assert out.strip().endswith("2 test cases, 2 run configurations checked: 3 problems")
    assert not builds.exists()  # nothing was built or run
    (targets / "broken.json").unlink()
    (cases / "typo" / "run.config").write_text(json.dumps({"runs": [{"name": "a", "script": "scene.json"}]}))
    assert main(["--targets", str(targets), "validate"]) == 0
    assert "0 problems" in capsys.readouterr().out


def test_new_testcase_writes_a_valid_test_case_once(tmp_path, capsys, store):
    assert harness("new", "testcase", "first_bounce", "--in", str(tmp_path)) == 0
    assert (tmp_path / "first_bounce" / "run.config").is_file()
    config = json.loads((tmp_path / "first_bounce" / "run.config").read_text())
    assert config["runs"][0]["expectations"] == [
        {"quantity": "thermo.vz[1]", "at": "end", "value": 0.9, "rel_tol": 0.01}]
    capsys.readouterr()
    assert harness("validate", "dem", "--testcases", str(tmp_path)) == 0
    assert "1 test case, 1 run configuration checked: 0 problems" in capsys.readouterr().out
    before = (tmp_path / "first_bounce" / "scene.json").read_text()
    assert harness("new", "testcase", "first_bounce", "--in", str(tmp_path)) == 1
    assert "exists already" in capsys.readouterr().err
    assert (tmp_path / "first_bounce" / "scene.json").read_text() == before  # nothing overwritten
    assert harness("new", "testcase", "../x", "--in", str(tmp_path)) != 0


def test_run_a_folder_outside_the_project_with_testcases(tmp_path, capsys, store):
    """A target's own test cases are not run; the folder's are, under its name, and check scores them."""
    repo = git_repo(tmp_path / "repo")
    scene = [{"command": "create", "heights": [1.0]}, {"command": "run", "steps": 100, "every": 20}]
    commit_files(repo, {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source(9.81),
                        "cases/own/scene.json": json.dumps(scene),
                        "cases/own/run.config": json.dumps({"runs": [{"name": "a", "script": "scene.json"}]})},
                 "v1", tag="v1")
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "fake.json").write_text(json.dumps({"repository": str(repo.working_tree_dir), "revision": "v1",
                                                   "testcases": ["cases"]}))
    mine = tmp_path / "elsewhere" / "my_cases"
    (mine / "drop").mkdir(parents=True)
    (mine / "drop" / "scene.json").write_text(json.dumps(scene))
    (mine / "drop" / "run.config").write_text(json.dumps({"runs": [
        {"name": "b", "script": "scene.json", "expectations": [{"quantity": "thermo.atoms", "value": 1, "abs_tol": 0}]}]}))
    assert main(["--machine", "m1", "--targets", str(targets), "run", "fake", "--testcases", str(mine)]) == 0
    out = capsys.readouterr().out
    assert "my_cases/drop" in out and "cases/own" not in out
    assert main(["--machine", "m1", "--targets", str(targets), "check", "fake", "--testcases", str(mine)]) == 0
    assert "1 runs: 1 passed" in capsys.readouterr().out
    assert main(["--machine", "m1", "--targets", str(targets), "run", "fake", "--testcases",
                 str(tmp_path / "nowhere")]) == 1
    assert "--testcases: " in (err := capsys.readouterr().err) and "no such folder" in err


@pytest.mark.slow
def test_first_test_case_of_the_readme_with_the_bundled_engine(tmp_path, capsys, store):
    """README.md, "Your first test case": write it, run it (it passes), break it (it fails, saying why)."""
    readme = (PROJECT_ROOT / "README.md").read_text()
    assert "harness new testcase first_bounce" in readme and "--testcases" in readme
    assert harness("new", "testcase", "first_bounce", "--in", str(tmp_path)) == 0
    assert harness("run", "dem", "--no-reference", "--testcases", str(tmp_path)) == 0
    out = capsys.readouterr()
    assert "1 runs: 1 ok" in out.out
    config = tmp_path / "first_bounce" / "run.config"
    config.write_text(config.read_text().replace('"E": 0.9', '"E": 0.5'))
    assert harness("run", "dem", "--no-reference", "--testcases", str(tmp_path)) == 1
    assert harness("check", "dem", "-v", "--testcases", str(tmp_path)) == 1
    out = " ".join(capsys.readouterr().out.split())
    assert "expectation thermo.vz[1] (end) = 0.5" in out and "outside 0.9 +/- 1 %" in out
