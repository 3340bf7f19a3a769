"""Build recipes for real codes on a tiny C++ CMake program: export folders, cmake options, env, jobs,
prebuild/postbuild, patches per commit range, requirements, ccache across commits, failed builds as stored
results, one build for two processes, Ctrl-C, bare repositories and bundles, one-line definition errors."""
import json
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest
from build_support import (
    commit_files,
    git_repo,
    harness,
    tiny_repo,
    tiny_target,
    write_target,
)

from harness.adapters.base import UserError
from harness.config.targets import load_target_file
from harness.execution.builds import BuildError, build_target, first_error_line

pytestmark = pytest.mark.skipif(not (shutil.which("cmake") and shutil.which("c++") and shutil.which("ccache")),
                                reason="needs cmake, a C++ compiler and ccache (scripts/setup.sh)")


def run_binary(build) -> str:
    return subprocess.run(json.loads(build.executable), capture_output=True, text=True, check=True).stdout.strip()


def test_cmake_recipe_exports_only_its_folder_and_applies_options_env_jobs_and_commands(store):
    repo = tiny_repo(store / "repo")
    path = write_target(store, "tiny", tiny_target(
        repo, revision="v1", env={"CXXFLAGS": '-DMARK=\\"from-env\\"'},
        prebuild=["echo prebuilt > PREBUILD_RAN"], postbuild=["test -f PREBUILD_RAN && echo ok > POSTBUILD_RAN"]))
    build = build_target(load_target_file(path), "m1", jobs=3)
    assert build.status == "complete"
    assert run_binary(build) == "hello from-env v1"
    folder = Path(build.folder)
    assert sorted(p.name for p in (folder / "src").iterdir()) == ["POSTBUILD_RAN", "PREBUILD_RAN", "src"]
    assert not (folder / "src" / "docs").exists()        # only what the recipe needs
    assert build.details["jobs"] == 3 and "--parallel 3" in build.log
    assert build.details["compiler"] and build.details["duration_s"] > 0
    assert build.details["cmake_options"]["CMAKE_BUILD_TYPE"] == "Release"
    assert "-DGREETING=hello" in build.log


def test_patches_apply_to_their_commit_range_with_their_flags_and_count_in_the_hash(store, monkeypatch):
    repo = tiny_repo(store / "repo")
    # the workspace inside a git checkout (as .harness/ in the project): patches still apply to the export
    monkeypatch.setenv("HARNESS_HOME", str(store / "repo" / ".harness"))
    fixed = commit_files(repo, {"src/other.cpp": 'const char *other() { return "fixed"; }\n'}, "fix", tag="fix")
    patch = store / "targets" / "patches" / "other.patch"
    patch.parent.mkdir(parents=True)
    patch.write_text("--- a/src/other.cpp\n+++ b/src/other.cpp\n@@ -1 +1 @@\n"
                     '-const char *other() { return "v1"; }\n+const char *other() { return "patched"; }\n')
    definition = tiny_target(repo, patches=[
        {"before": "v2", "files": ["patches/other.patch"], "cmake_options": {"GREETING": "old"}},
        {"from": "v2", "before": "fix", "env": {"CXXFLAGS": '-DMARK=\\"between\\"'}}])
    outputs = {}
    for revision in ("v1", "v2", "fix"):
        target = load_target_file(write_target(store, f"t-{revision}", {**definition, "revision": revision}))
        build = build_target(target, "m1")
        outputs[revision] = run_binary(build)
        applied = build.details["patches"]
        assert applied == (["other.patch"] if revision == "v1" else [])
    assert outputs == {"v1": "old unmarked patched", "v2": "hello between v2", "fix": "hello unmarked fixed"}
    assert fixed
    before = load_target_file(store / "targets" / "t-v1.json").definition_hash
    patch.write_text(patch.read_text().replace("patched", "patched again"))
    assert load_target_file(store / "targets" / "t-v1.json").definition_hash != before


def test_a_compile_error_is_a_stored_failed_build_with_its_first_error_line(store):
    repo = tiny_repo(store / "repo")
    commit_files(repo, {"src/other.cpp": "const char *other() { return undeclared_name; }\n"}, "broken",
                 tag="broken")
    target = load_target_file(write_target(store, "tiny", tiny_target(repo, revision="broken")))
    with pytest.raises(BuildError) as info:
        build_target(target, "m1")
    first_line = str(info.value).splitlines()[0]
    assert "other.cpp:1:" in first_line and "error:" in first_line and "undeclared_name" in first_line
    from harness.store.models import Build

    build = Build.objects.get(target__name="tiny")
    assert build.status == "failed" and build.duration > 0 and "undeclared_name" in build.details["error"]
    assert not (Path(build.folder) / "done").exists()
    finished = build.finished
    with pytest.raises(BuildError, match="undeclared_name"):   # the stored failure, not a second build
        build_target(target, "m1")
    build.refresh_from_db()
    assert build.finished == finished
    with pytest.raises(BuildError):                            # --force builds it again
        build_target(target, "m1", force=True)
    build.refresh_from_db()
    assert build.finished > finished


def test_a_configure_error_is_a_failed_build_naming_cmakes_message(store):
    repo = tiny_repo(store / "repo")
    commit_files(repo, {"src/CMakeLists.txt": "cmake_minimum_required(VERSION 3.13)\nproject(tiny CXX)\n"
                        'message(FATAL_ERROR "this code needs libfoo")\n'}, "needs foo", tag="foo")
    target = load_target_file(write_target(store, "tiny", tiny_target(repo, revision="foo")))
    with pytest.raises(BuildError) as info:
        build_target(target, "m1")
    assert "CMake Error at" in str(info.value).splitlines()[0]
    assert "this code needs libfoo" in str(info.value).splitlines()[0]


def test_first_error_line_prefers_the_compilers_line():
    log = ("[ 50%] Building CXX object x.o\nIn file included from a.cpp:3:\nb.h:7:12: warning: unused\n"
           "b.h:9:3: error: 'x' was not declared in this scope\nmake[2]: *** [x.o] Error 1\n")
    assert first_error_line(log) == "b.h:9:3: error: 'x' was not declared in this scope"
    assert first_error_line("all fine\n") is None
    assert first_error_line("x.o: in function main:\nmain.cpp:(.text+0x5): undefined reference to `f()'\n"
                            "collect2: error: ld returned 1 exit status\n").endswith("undefined reference to `f()'")


def test_ccache_makes_the_next_commit_compile_only_what_changed(store):
    repo = tiny_repo(store / "repo")
    builds = {}
    for revision in ("v1", "v2"):
        target = load_target_file(write_target(store, f"t-{revision}", tiny_target(repo, revision=revision)))
        builds[revision] = build_target(target, "m1")
    stats = builds["v2"].details["ccache_stats"]
    # v2 changed other.cpp only: main.cpp comes from the cache although it lies in another build folder
    assert stats["cache_miss"] == 1
    assert stats.get("direct_cache_hit", 0) + stats.get("preprocessed_cache_hit", 0) == 1
    assert builds["v1"].details["ccache_stats"]["cache_miss"] == 2
    assert (store / "home" / "ccache").is_dir()
    assert run_binary(builds["v2"]) == "hello unmarked v2"


def test_requirements_are_checked_first_and_a_miss_is_one_line(store):
    repo = tiny_repo(store / "repo")
    path = write_target(store, "tiny", tiny_target(repo, requires=["cmake", "no-such-build-tool"]))
    with pytest.raises(UserError) as info:
        build_target(load_target_file(path), "m1")
    text = str(info.value)
    assert "\n" not in text and str(path) in text and "$.requires" in text
    assert "no-such-build-tool" in text and "sudo apt-get install no-such-build-tool" in text
    if shutil.which("dpkg-query"):
        path = write_target(store, "tiny", tiny_target(repo, requires=[{"package": "no-such-dev-package"}]))
        with pytest.raises(UserError, match=r"Debian package no-such-dev-package.*apt-get install "
                                            r"no-such-dev-package"):
            build_target(load_target_file(path), "m1")
    from harness.store.models import Build

    assert not Build.objects.exists()                      # nothing started


@pytest.mark.parametrize("field, value, expected", [
    ("recipe", "ninja", "$.recipe: unknown recipe 'ninja'"),
    ("jobs", 0, "$.jobs: must be at least 1"),
    ("jobs", "2", "$.jobs: must be an integer"),
    ("cmake_options", ["-DX=1"], "$.cmake_options: must be an object"),
    ("configure", ["./configure"], "$.configure: only for the make recipe"),
    ("export", ["../outside"], "$.export: folder '../outside' must be relative"),
    ("requires", [3], "$.requires[0]: must be an executable name"),
    ("requires", [{"pkg": "x"}], "$.requires[0]: an object has"),
    ("patches", [{"files": ["missing.patch"]}], "$.patches[0].files[0]: patch file 'missing.patch' not found"),
    ("patches", [{"until": "v2"}], "$.patches[0].until: unknown field"),
    ("patches", [{"before": ""}], "$.patches[0].before: must name a revision"),
    ("on_demand", "yes", "$.on_demand: must be true or false"),
])
def test_recipe_errors_are_one_line_naming_file_and_field(tmp_path, field, value, expected):
    definition = {"repository": str(tmp_path), "recipe": "cmake", "generated_executable": "x", field: value}
    path = write_target(tmp_path, "broken", definition)
    with pytest.raises(UserError) as info:
        load_target_file(path)
    text = str(info.value)
    assert text.count("\n") == 0 and str(path) in text and expected in text, text


def test_cmake_needs_generated_executable_and_dem_refuses_build_fields(tmp_path):
    with pytest.raises(UserError, match=r"\$\.generated_executable: required for the cmake recipe"):
        load_target_file(write_target(tmp_path, "a", {"recipe": "cmake"}))
    with pytest.raises(UserError, match=r"\$\.patches: only for the make and cmake recipes"):
        load_target_file(write_target(tmp_path, "b", {"recipe": "dem", "patches": []}))


def test_bare_repository_and_bundle_resolve_every_rev_parse_spelling(store):
    from harness.config import gitrepo

    repo = tiny_repo(store / "work")
    v1 = repo.commit("v1").hexsha
    repo.create_tag("3.8.0", ref="v1", message="an annotated release tag")
    bare = store / "mirror.git"
    subprocess.run(["git", "clone", "-q", "--mirror", str(store / "work"), str(bare)], check=True)
    bundle = store / "history.bundle"
    subprocess.run(["git", "-C", str(store / "work"), "bundle", "create", str(bundle), "--all"], check=True,
                   capture_output=True)
    for location in (str(bare), str(bundle)):
        handle = gitrepo.open_repository(location)
        for spelling in ("3.8.0", "v2~1", "HEAD^", ":/^v1", "v1^{commit}", v1[:7]):
            assert gitrepo.resolve(handle, spelling).hexsha == v1, (location, spelling)
        with pytest.raises(UserError, match="revision 'v9' not found"):
            gitrepo.resolve(handle, "v9")
    target = load_target_file(write_target(store, "from-bundle", {**tiny_target(repo), "repository": str(bundle),
                                                                   "revision": "3.8.0"}))
    assert run_binary(build_target(target, "m1")) == "hello unmarked v1"


def test_two_processes_build_a_commit_once(store):
    repo = tiny_repo(store / "repo")
    write_target(store, "tiny", tiny_target(repo, prebuild=["sleep 2"]))
    first = harness(store / "home", store / "targets", "build", "tiny", popen=True)
    time.sleep(0.5)
    second = harness(store / "home", store / "targets", "build", "tiny", popen=True)
    outputs = [p.communicate(timeout=300) for p in (first, second)]
    assert first.returncode == 0 and second.returncode == 0, outputs
    started = [line for _out, err in outputs for line in err.splitlines() if line.startswith("building tiny at")]
    assert len(started) == 1 and "waiting for another harness process" in "".join(e for _o, e in outputs)
    folders = {out.split()[-1] for out, _err in outputs}
    assert len(folders) == 1


def test_ctrl_c_during_a_build_leaves_no_half_built_cache_entry(store):
    repo = tiny_repo(store / "repo")
    write_target(store, "tiny", tiny_target(repo, prebuild=['sleep "${HOLD:-0}"']))
    process = harness(store / "home", store / "targets", "build", "tiny", popen=True, env={"HOLD": "60"})
    deadline = time.time() + 60
    folders = []
    while time.time() < deadline and not folders:
        folders = list((store / "home" / "builds" / "tiny").glob("*/build.log"))
        time.sleep(0.2)
    assert folders, "the build did not start"
    time.sleep(1.0)
    process.send_signal(signal.SIGINT)
    _out, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    folder = folders[0].parent
    assert not (folder / "done").exists() and not (folder / "bin").exists()
    again = harness(store / "home", store / "targets", "build", "tiny")
    assert again.returncode == 0, again.stderr
    assert "building tiny at" in again.stderr and (folder / "done").is_file()


def test_build_without_names_leaves_on_demand_targets_out(store):
    repo = tiny_repo(store / "repo")
    write_target(store, "everyday", tiny_target(repo, revision="v1"))
    write_target(store, "expensive", tiny_target(repo, revision="v2", on_demand=True))
    result = harness(store / "home", store / "targets", "build")
    assert result.returncode == 0, result.stderr
    assert "everyday:" in result.stdout and "expensive" not in result.stdout + result.stderr
    named = harness(store / "home", store / "targets", "build", "expensive", "-j", "1")
    assert named.returncode == 0 and "expensive:" in named.stdout
    bad = harness(store / "home", store / "targets", "build", "expensive", "-j", "0")
    assert bad.returncode == 1 and bad.stderr == "harness: error: -j 0: must be at least 1\n"


def test_the_liggghts_src_definition_loads_and_its_patch_ranges_name_commits_of_the_bundle():
    from harness.config import gitrepo

    target = load_target_file(Path(__file__).resolve().parents[2] / "targets" / "liggghts-src.json")
    assert target.on_demand and target.recipe == "cmake" and target.export == ["src"]
    assert [p.name for entry in target.patches for p in entry["files"]] == [
        "utils-int-to-string.patch", "finish-pointer-comparison.patch", "vtk9-cmake-use-file.patch",
        "vtk9-cmake-use-file-enable-vtk.patch"]
    assert target.cmake_options == {"ENABLE_VTK": "ON"}
    if Path(target.repository).is_file():   # the fixture bundle (../shared/fixtures)
        repo = gitrepo.open_repository(target.repository)
        for entry in target.patches:
            for key in ("from", "before"):
                if entry[key]:
                    assert gitrepo.resolve(repo, entry[key]).hexsha == entry[key]


@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_make_recipe_runs_its_configure_commands_first_with_jobs_and_ccache(store):
    repo = git_repo(store / "repo")
    makefile = ("include config.mk\nhello: hello.o\n\tc++ -o hello hello.o\n"
                "hello.o: hello.cpp\n\tc++ -c -DGREETING='\"$(GREETING)\"' -o hello.o hello.cpp\n")
    source = '#include <cstdio>\nint main() { std::printf("%s\\n", GREETING); return 0; }\n'
    commit_files(repo, {"src/Makefile": makefile, "src/hello.cpp": source}, "v1")
    path = write_target(store, "hello", {"repository": str(repo.working_tree_dir), "recipe": "make",
                                         "source_folder": "src", "make_target": "hello",
                                         "generated_executable": "hello", "jobs": 2,
                                         "configure": ["echo GREETING=configured > config.mk"]})
    build = build_target(load_target_file(path), "m1")
    assert run_binary(build) == "configured"
    assert "echo GREETING=configured > config.mk" in build.log and "make -j2 hello" in build.log
    if Path("/usr/lib/ccache").is_dir():   # Debian's compiler names that call ccache
        assert build.details["ccache_stats"]["cache_miss"] == 1


def test_a_patch_that_does_not_apply_is_a_failed_build_naming_the_patch(store):
    repo = tiny_repo(store / "repo")
    patch = store / "targets" / "patches" / "stale.patch"
    patch.parent.mkdir(parents=True)
    patch.write_text("--- a/src/other.cpp\n+++ b/src/other.cpp\n@@ -1 +1 @@\n"
                     '-const char *other() { return "v0"; }\n+const char *other() { return "x"; }\n')
    target = load_target_file(write_target(store, "tiny", tiny_target(repo, revision="v1",
                                                                       patches=[{"files": ["patches/stale.patch"]}])))
    with pytest.raises(BuildError) as info:
        build_target(target, "m1")
    first_line = str(info.value).splitlines()[0]
    assert "error: patch failed: src/other.cpp:1" in first_line, first_line
    assert "applying patch stale.patch exited with code 1" in str(info.value)


def test_the_liggghts_src_patches_apply_to_every_commit_of_their_ranges_and_give_each_cmakelists_vtk_9(tmp_path):
    """Every first-parent commit of the bundle, with the patches the build would apply to it: each applies,
    and no CMakeLists is left that takes VTK's header folders from its use file alone (VTK 9's use file only
    warns, and the VTK dumps then miss their headers)."""
    import re

    from harness.config import gitrepo
    from harness.execution.builds import _in_range

    target = load_target_file(Path(__file__).resolve().parents[2] / "targets" / "liggghts-src.json")
    if not Path(target.repository).is_file():
        pytest.skip("the fixture bundle ../shared/fixtures/liggghts-public-src.bundle is missing")
    repo = gitrepo.open_repository(target.repository)
    commits = repo.git.rev_list("--first-parent", "HEAD").split()
    assert len(commits) == 35
    touched = {p: re.findall(r"^\+\+\+ b/(\S+)", p.read_text(), re.M)
               for entry in target.patches for p in entry["files"]}
    for commit in commits:
        folder = tmp_path / commit
        patches = [p for entry in target.patches if _in_range(repo, commit, entry) for p in entry["files"]]
        files = sorted({f for p in patches for f in touched[p]} | {"src/CMakeLists.txt"})
        folder.mkdir()
        archive = subprocess.run(["git", "archive", commit, *files], cwd=repo.git_dir, capture_output=True,
                                 check=True).stdout
        subprocess.run(["tar", "x"], input=archive, cwd=folder, check=True)
        for patch in patches:
            applied = subprocess.run(["git", "apply", "-p1", str(patch)], cwd=folder, capture_output=True,
                                     text=True, env={"GIT_CEILING_DIRECTORIES": str(tmp_path), "PATH": "/usr/bin:/bin"})
            assert applied.returncode == 0, (commit[:7], patch.name, applied.stderr)
        cmakelists = (folder / "src" / "CMakeLists.txt").read_text().splitlines()
        for i, line in enumerate(cmakelists):
            if "INCLUDE(${VTK_USE_FILE})" in line:
                assert 'IF(VTK_VERSION VERSION_LESS "8.90.0")' in cmakelists[i - 1], (commit[:7], i)
