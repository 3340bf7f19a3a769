"""A planted commit that does not compile is a failed build (stored, with the compiler's first error line)
and bisect skips it. The engine under test is the fake engine of tests/harness behind a tiny C++ launcher
built with CMake, so that every commit is a real C++ build (about a second each)."""
import json
import shutil
import sys

import pytest
from build_support import (CMAKELISTS_LAUNCHER, FAKE_ENGINE, LAUNCHER, SCENE, commit_files, git_repo, harness,
                           write_target)

pytestmark = pytest.mark.skipif(not (shutil.which("cmake") and shutil.which("c++")),
                                reason="needs cmake and a C++ compiler (scripts/setup.sh)")

def test_bisect_skips_a_commit_that_does_not_compile(tmp_path):
    repo = git_repo(tmp_path / "repo")
    commit_files(repo, {"engine/__main__.py": FAKE_ENGINE, "engine/launcher.cpp": LAUNCHER,
                        "engine/CMakeLists.txt": CMAKELISTS_LAUNCHER, "cases/fall/scene.json": SCENE,
                        "cases/fall/run.config": json.dumps({"runs": [{"name": "drop", "script": "scene.json"}]})},
                 "start", tag="good")
    commits = []
    for i in range(6):
        files = {"NOTES.txt": f"note {i}\n"}
        if i == 2:   # the planted commit that does not compile (fixed by the next one)
            files["engine/launcher.cpp"] = LAUNCHER.replace("return 127;", "return undeclared_status;")
        if i == 3:
            files["engine/launcher.cpp"] = LAUNCHER
        if i == 4:   # the planted break: gravity 10 % larger
            files["engine/__main__.py"] = FAKE_ENGINE.replace("G = 9.81  #", f"G = {9.81 * 1.1!r}  #")
        commits.append(commit_files(repo, files, f"change {i}"))
    write_target(tmp_path, "t", {"repository": str(repo.working_tree_dir), "revision": "HEAD", "recipe": "cmake",
                                 "source_folder": "engine", "generated_executable": "fake_engine",
                                 "cmake_options": {"PYTHON": sys.executable}, "engine": "dem",
                                 "testcases": ["cases"], "testcases_revision": "working-tree"})
    home, targets = tmp_path / "home", tmp_path / "targets"
    result = harness(home, targets, "bisect", "t", "good", "HEAD")
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"first bad commit: {commits[4]}" in result.stdout and "1 skipped" in result.stdout
    skip_line = next(line for line in result.stderr.splitlines() if "skip" in line)
    assert commits[2][:10] in skip_line and "launcher.cpp" in skip_line and "undeclared_status" in skip_line
    # the failed build is a stored result: a build of that commit says so at once, with the error line
    again = harness(home, targets, "build", f"t@{commits[2]}")
    assert again.returncode == 1
    assert "error:" in again.stderr and "undeclared_status" in again.stderr.splitlines()[0]
    assert "building t at" not in again.stderr
    listed = harness(home, targets, "regressions", "t", "--builds", "--json")
    builds = {b["commit"]: b for b in json.loads(listed.stdout)}
    assert builds[commits[2]]["status"] == "failed" and "undeclared_status" in builds[commits[2]]["error"]
    assert all(b["seconds"] > 0 for b in builds.values())
    assert builds[commits[4]]["status"] == "complete"
