"""LIGGGHTS-PUBLIC built from its own history (the git bundle of the shared fixtures) with CMake and ccache,
then run on a LIGGGHTS test case: two adjacent commits (the second through ccache), and the release 3.8.0
with the patches that make it compile with today's GCC. Slow (a cold build takes minutes): the tests share
one ccache folder (``shared_ccache``), so a second session, or the second commit, compiles only what changed.
"""
import json
import math
import shutil
import sqlite3
from pathlib import Path

import pytest
from build_support import ROOT, harness

TARGET = json.loads((ROOT / "targets" / "liggghts-src.json").read_text())
BUNDLE = (ROOT / TARGET["repository"]).resolve()

pytestmark = [pytest.mark.slow, pytest.mark.skipif(
    not (shutil.which("cmake") and shutil.which("ccache") and shutil.which("mpicxx")),
    reason="needs cmake, ccache and libopenmpi-dev (scripts/setup.sh)")]


@pytest.fixture
def project(tmp_path, shared_ccache):
    """The liggghts-src target as committed (its bundle and patches), a fresh workspace, the shared ccache."""
    assert BUNDLE.is_file(), f"the fixture bundle {BUNDLE} is missing"
    targets = tmp_path / "targets"
    shutil.copytree(ROOT / "targets" / "patches", targets / "patches")
    # our wall impact scene without its VTK dump: the target builds LIGGGHTS without VTK, which has no
    # 'dump custom/vtk' (docs/liggghts.md)
    scene = tmp_path / "scenes" / "wall_impact"
    shutil.copytree(ROOT / "testcases" / "liggghts" / "wall_impact", scene)
    script = scene / "in.impact"
    script.write_text("".join(line for line in script.read_text().splitlines(keepends=True)
                              if not line.startswith("dump")))
    for name in ("liggghts-src", "liggghts"):
        definition = json.loads((ROOT / "targets" / f"{name}.json").read_text())
        if name == "liggghts-src":   # the same repository, named absolutely from the copy
            definition["repository"] = str(BUNDLE)
            definition["testcases"] = [str(scene)]
        (targets / f"{name}.json").write_text(json.dumps(definition))
    return {"home": tmp_path / "home", "targets": targets, "env": {"HARNESS_CCACHE_DIR": str(shared_ccache)}}


def build(project, revision):
    result = harness(project["home"], project["targets"], "build", f"liggghts-src@{revision}", "-j", "2",
                     env=project["env"], timeout=3600)
    assert result.returncode == 0, result.stdout + result.stderr[-3000:]
    with sqlite3.connect(project["home"] / "harness.sqlite3") as db:
        commit, details, folder = db.execute(
            "SELECT b.\"commit\", b.details, b.folder FROM harness_build b JOIN harness_target t "
            "ON b.target_id = t.id WHERE t.name = 'liggghts-src' ORDER BY b.id DESC LIMIT 1").fetchone()
    return commit, json.loads(details), Path(folder)


def rebound_ratio(project, commit) -> float:
    """sqrt(ke after / ke before) of the wall_impact run of liggghts-src at ``commit``: the restitution."""
    result = harness(project["home"], project["targets"], "run", f"liggghts-src@{commit}", "-k", "wall_impact",
                     "--no-reference", env=project["env"], timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr[-3000:]
    with sqlite3.connect(project["home"] / "harness.sqlite3") as db:
        folder, state = db.execute(
            "SELECT r.folder, r.state FROM harness_run r JOIN harness_build b ON r.build_id = b.id "
            "WHERE b.\"commit\" = ? ORDER BY r.id DESC LIMIT 1", (commit,)).fetchone()
    assert state == "post_processed", state
    from harness.adapters import get_adapter

    thermo = get_adapter("liggghts").read_thermo(Path(folder))
    return math.sqrt(thermo["ke"].iloc[-1] / thermo["ke"].iloc[0])


def test_two_adjacent_commits_the_second_through_ccache_then_a_liggghts_run_on_each(project):
    # HEAD~3 -> HEAD~2 changes one source file (input_mesh_tri.cpp, "fix-generate-mesh")
    first, cold, _ = build(project, "HEAD~3")
    assert cold["patches"] == [] and cold["ccache"] is True
    second, warm, folder = build(project, "HEAD~2")
    assert first != second
    # only what changed is compiled: input_mesh_tri.cpp, and the few files that include LIGGGHTS' generated
    # headers (style_*.h name the build folder's absolute paths, version_liggghts.h the build time; measured:
    # 9 misses of 328, docs/liggghts.md)
    assert warm["ccache_stats"]["cache_miss"] <= 12, warm["ccache_stats"]
    hits = warm["ccache_stats"]["direct_cache_hit"] + warm["ccache_stats"]["preprocessed_cache_hit"]
    assert hits > 300
    if cold["ccache_stats"]["cache_miss"] > 300:   # the first build was cold in this cache
        assert warm["duration_s"] <= cold["duration_s"] / 4, (warm["duration_s"], cold["duration_s"])
    assert (folder / "bin" / "liggghts-src").is_file()
    for revision in (first, second):
        # the Hertz wall impact rebounds with the input restitution e = 0.5 (LIGGGHTS' damping model)
        assert rebound_ratio(project, revision) == pytest.approx(0.5, rel=0.01)


def test_release_3_8_0_builds_with_its_patches(project):
    commit, details, folder = build(project, "3.8.0")
    assert details["patches"] == ["utils-int-to-string.patch", "finish-pointer-comparison.patch",
                                  "dump-mesh-vtk-without-vtk.patch"]
    assert "LIGGGHTS (Version LIGGGHTS-PUBLIC 3.8.0" in _version_banner(folder / "bin" / "liggghts-src")
    assert rebound_ratio(project, commit) == pytest.approx(0.5, rel=0.01)


def _version_banner(binary: Path) -> str:
    import subprocess

    # in the build folder: LIGGGHTS writes log.liggghts where it runs
    result = subprocess.run([str(binary), "-h"], capture_output=True, text=True, timeout=60, cwd=binary.parent)
    return result.stdout + result.stderr
