"""Builds from git: the bundled-engine recipe, make (a C program), system; caching and outdated results."""
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from harness_support import commit_files, fake_engine_source, git_repo

from harness.adapters.base import UserError
from harness.config.targets import load_target_file
from harness.execution.builds import BuildError, build_target, sha256_file

HELLO_C = '#include <stdio.h>\nint main(void) { printf("%s\\n", GREETING); return 0; }\n'
MAKEFILE = "hello_%: hello.c\n\t$(CC) -DGREETING='\"$(GREETING)\"' -o $@ hello.c\n"


def target_file(repo_root: Path, name: str, data: dict) -> Path:
    path = repo_root.parent / "targets" / f"{name}.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps({"repository": str(repo_root), **data}))
    return path


def test_dem_recipe_exports_the_commit_not_the_working_tree(store):
    repo = git_repo(store / "repo")
    first = commit_files(repo, {"engine/__main__.py": fake_engine_source(9.81), "engine/__init__.py": ""}, "v1",
                         tag="v1")
    commit_files(repo, {"engine/__main__.py": fake_engine_source(5.0)}, "v2")
    target = load_target_file(target_file(store / "repo", "old", {"revision": "v1"}))
    build = build_target(target, "m1")
    assert build.commit == first and build.status == "complete"
    command = json.loads(build.executable)
    assert command == [sys.executable, "-m", "engine"]
    # the working tree changes after the build: the build still holds v1
    (store / "repo" / "engine" / "__main__.py").write_text("raise SystemExit(3)\n")
    source = Path(build.environment["PYTHONPATH"]) / "engine" / "__main__.py"
    assert "G = 9.81" in source.read_text()
    assert build_target(target, "m1").id == build.id                       # cached
    assert "exported engine" in build.log


def test_revision_not_found_and_missing_engine(store):
    repo = git_repo(store / "repo")
    commit_files(repo, {"README": "no engine here"}, "v1")
    target = load_target_file(target_file(store / "repo", "t", {"revision": "no-such-tag"}))
    with pytest.raises(UserError, match="revision 'no-such-tag' not found"):
        build_target(target, "m1")
    target = load_target_file(target_file(store / "repo", "t", {}))
    with pytest.raises(BuildError, match="cannot export 'engine'.*no such folder at that commit"):
        build_target(target, "m1")
    from harness.store.models import Build

    assert Build.objects.get(target__name="t").status == "failed"


@pytest.mark.skipif(shutil.which("make") is None or shutil.which("cc") is None, reason="needs make and cc")
def test_make_recipe_two_revisions_cached_and_a_compile_error(store):
    repo = git_repo(store / "repo")
    files = {"src/hello.c": HELLO_C, "src/Makefile": MAKEFILE}
    commit_files(repo, files, "v1", tag="v1")
    commit_files(repo, {"src/hello.c": HELLO_C.replace("%s\\n", "v2 %s\\n")}, "v2", tag="v2")
    commit_files(repo, {"src/hello.c": "int main(void) { return undefined_symbol; }\n"}, "broken", tag="broken")
    definition = {"source_folder": "src", "make_target": "hello_fedora", "make_variables": {"GREETING": "hi"},
                  "generated_executable": "hello_fedora"}
    outputs = {}
    for tag in ("v1", "v2"):
        target = load_target_file(target_file(store / "repo", f"hello-{tag}", {**definition, "revision": tag}))
        build = build_target(target, "m1")
        binary = json.loads(build.executable)
        outputs[tag] = subprocess.run(binary, capture_output=True, text=True).stdout.strip()
        again = build_target(target, "m1")
        assert again.id == build.id and again.finished == build.finished        # cached, not rebuilt
    assert outputs == {"v1": "hi", "v2": "v2 hi"}
    target = load_target_file(target_file(store / "repo", "hello-broken", {**definition, "revision": "broken"}))
    with pytest.raises(BuildError) as info:
        build_target(target, "m1")
    assert "make exited with code 2" in str(info.value)
    assert "undefined_symbol" in str(info.value)                 # the log tail is in the message
    log = Path(str(info.value).split("(log: ")[1].split(")")[0])
    assert "undefined_symbol" in log.read_text()


def test_system_recipe_commit_is_the_binary_digest(store, tmp_path):
    binary = tmp_path / "fake-liggghts"
    binary.write_text("#!/bin/sh\necho v1\n")
    binary.chmod(0o755)
    path = tmp_path / "targets" / "sys.json"
    path.parent.mkdir()
    path.write_text(json.dumps({"recipe": "system", "executable": str(binary), "engine": "dem"}))
    build = build_target(load_target_file(path), "m1")
    assert build.commit == sha256_file(binary)
    assert json.loads(build.executable) == [str(binary)]
    binary.write_text("#!/bin/sh\necho v2\n")                      # the package was upgraded
    assert build_target(load_target_file(path), "m1").id != build.id
    path.write_text(json.dumps({"recipe": "system", "executable": "no-such-program-xyz"}))
    with pytest.raises(UserError, match=r"\$\.executable: 'no-such-program-xyz' not found"):
        build_target(load_target_file(path), "m1")


def test_a_new_binary_makes_earlier_runs_outdated(store):
    from harness.store.models import Run, TestCase

    repo = git_repo(store / "repo")
    commit_files(repo, {"engine/__main__.py": fake_engine_source(), "engine/__init__.py": ""}, "v1")
    target = load_target_file(target_file(store / "repo", "t", {}))
    first = build_target(target, "m1")
    run = Run.objects.create(machine=first.machine, target=first.target, build=first, name="r",
                             testcase=TestCase.objects.create(path="c"), state="post_processed")
    assert build_target(target, "m1").id == first.id
    run.refresh_from_db()
    assert run.state == "post_processed"                         # same binary: nothing outdated
    commit_files(repo, {"engine/README": "docs"}, "v2")
    build_target(target, "m1")
    run.refresh_from_db()
    assert run.state == "outdated"
    run.state = "post_processed"
    run.save()
    forced = build_target(target, "m1", force=True)                # rebuilt binary of the same commit
    run.refresh_from_db()
    assert run.state == "outdated" and forced.status == "complete"


def test_repository_url_is_mirrored_and_fetched(store):
    repo = git_repo(store / "upstream")
    first = commit_files(repo, {"engine/__main__.py": fake_engine_source(), "engine/__init__.py": ""}, "v1")
    path = store / "targets" / "remote.json"
    path.parent.mkdir()
    path.write_text(json.dumps({"repository": (store / "upstream").as_uri(), "revision": "HEAD"}))
    target = load_target_file(path)
    assert target.repository.startswith("file://")
    assert build_target(target, "m1").commit == first
    second = commit_files(repo, {"engine/NOTES": "new upstream commit"}, "v2")
    assert build_target(target, "m1").commit == second        # the mirror fetched the new commit
