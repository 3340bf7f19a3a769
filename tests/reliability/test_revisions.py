"""Revisions first: TARGET@REV and ranges, compare two revisions, bisect a planted break to its commit.
All through the real CLI on temporary git repositories holding the fake engine (tests/harness/fake_engine)
and, marked slow, on a scratch clone of this repository with a planted change to the bundled engine."""
import json
import math
import subprocess

import pytest
from provenance_support import (
    ROOT,
    commit_files,
    fake_engine_source,
    git_repo,
    harness,
    make_project,
    rows,
    scene,
    write_target,
)


def _ok(result):
    assert result.returncode == 0, result.stdout + result.stderr
    return result


def test_run_at_revisions_and_ranges_without_moving_the_current_build(tmp_path):
    project = make_project(tmp_path)
    v1, v2 = project["v1"], project["v2"]
    _ok(harness(project, "run", "dev", "--no-reference"))
    out = harness(project, "run", "dev@v2", "--no-reference")
    assert out.returncode == 0 and v2[:10] in out.stdout
    # dev's own revision (v1) stays the current build: status, list and check say v1
    assert v1[:10] in next(l for l in _ok(harness(project, "status")).stdout.splitlines() if l.startswith("dev "))
    assert v2[:10] not in _ok(harness(project, "list", "dev")).stdout
    # a range: every commit after v1 up to v2 (here only v2, already run)
    again = _ok(harness(project, "run", "dev@v1..v2", "--no-reference"))
    assert "0 runs" in again.stdout and "4 already done" in again.stdout
    bad = harness(project, "run", "dev@nosuchrev")
    assert bad.returncode == 1 and bad.stderr.count("\n") == 1 and "revision 'nosuchrev' not found" in bad.stderr


def max_relative_ke_deviation(heights, g_a, g_b, steps, every, dt):
    """max_k |ke_b - ke_a| / max_k |ke_a| of particles dropped from rest onto an elastic floor (m = 1 kg)."""
    def ke(g, t):
        total = 0.0
        for h in heights:
            period = 2 * math.sqrt(2 * h / g)
            tau = t % period
            tau = min(tau, period - tau)
            total += g * (0.5 * g * tau * tau)
        return total

    times = [k * dt for k in range(0, steps + 1, every)]
    a = [ke(g_a, t) for t in times]
    b = [ke(g_b, t) for t in times]
    return max(abs(x - y) for x, y in zip(a, b)) / max(abs(x) for x in a)


def test_compare_two_revisions_text_json_markdown(tmp_path):
    project = make_project(tmp_path)
    same = _ok(harness(project, "compare", "dev@v1", "ref"))
    assert "4 consistent, 0 inconsistent, 0 new failures" in same.stdout
    result = harness(project, "compare", "dev@v1", "dev@v2", "--json")
    assert result.returncode == 1  # v2's gravity is 30 % larger: inconsistent
    data = json.loads(result.stdout)
    assert data["counts"]["inconsistent"] == 4 and data["failed"] is True
    assert data["a"]["commit"] == project["v1"] and data["b"]["commit"] == project["v2"]
    pair = data["pairs"][0]
    ke = next(q for q in pair["quantities"] if q["quantity"] == "ke")
    # independently: the fake engine's analytic bouncing trajectory, ke = sum m g (h0 - z), at both g
    expected = max_relative_ke_deviation([1.0, 0.5], 9.81, 9.81 * 1.3, steps=200, every=20, dt=1e-3)
    assert ke["level"] == "inconsistent"
    assert ke["max_relative_deviation"] == pytest.approx(expected, rel=1e-9)
    assert ke["first_bad_step"] is not None and data["time_ratio"] == pytest.approx(1.0)
    markdown = harness(project, "compare", "dev@v1", "dev@v2", "--markdown", "-k", "c0/a").stdout
    assert markdown.startswith("### dev@v2 against dev@v1: **failed**")
    assert "| cases/c0 | a | inconsistent |" in markdown and markdown.count("\n| cases/") == 1
    none = harness(project, "compare", "dev@v1", "dev@v2", "-k", "nothing-matches", "--no-run")
    assert none.returncode == 5


def test_bisect_finds_a_planted_break_among_sixteen_commits(tmp_path):
    repo = git_repo(tmp_path / "repo")
    commit_files(repo, {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source(9.81),
                        "cases/fall/scene.json": scene(1.0, steps=100),
                        "cases/fall/run.config": json.dumps({"runs": [{"name": "drop", "script": "scene.json"}]})},
                 "start", tag="good")
    commits = []
    for i in range(17):
        files = {"NOTES.txt": f"note {i}\n"}
        if i == 11:  # the planted break: gravity 10 % larger
            files["engine/__main__.py"] = fake_engine_source(9.81 * 1.1)
        commits.append(commit_files(repo, files, f"change {i}" + (" (gravity)" if i == 11 else "")))
    targets = tmp_path / "targets"
    targets.mkdir()
    write_target(targets, "t", revision="HEAD", repo=repo)
    project = {"targets": targets, "home": tmp_path / "home"}
    result = _ok(harness(project, "bisect", "t", "good", "HEAD"))
    assert f"first bad commit: {commits[11]}" in result.stdout
    assert "change 11 (gravity)" in result.stdout and "author: Test <test@example.org>" in result.stdout
    assert "cases/fall/drop ke: C = " in result.stdout and "first bad step" in result.stdout
    tested = int(result.stdout.split("(")[-1].split(" commits tested")[0])
    assert tested <= 6  # BAD, then about log2(17) = 4.1 halvings
    builds = rows(project, "SELECT COUNT(*) FROM harness_build")[0][0]
    assert builds == tested + 1  # and GOOD; no commit built twice


@pytest.mark.slow
def test_bisect_finds_a_planted_change_to_the_bundled_engine(tmp_path):
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    subprocess.run(["git", "-C", str(clone), "tag", "good"], check=True)
    repo = git_repo(clone)
    laws = clone / "engine" / "contact_laws.py"
    text = laws.read_text()
    damping = "gt = -2.0 * 0.9128709291752769"  # tangential damping, -2 sqrt(5/6) beta sqrt(St m*)
    assert damping in text, "the tangential damping line moved: update the planted change"
    commit_files(repo, {"NOTES.txt": "unrelated\n"}, "docs only")
    planted = text.replace(damping, "gt = -1.0 * 0.9128709291752769", 1)
    broken = commit_files(repo, {"engine/contact_laws.py": planted}, "halve the tangential damping")
    commit_files(repo, {"NOTES.txt": "unrelated again\n"}, "docs only again")
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "dem.json").write_text(json.dumps({"repository": str(clone), "revision": "HEAD",
                                                  "testcases": [str(ROOT / "testcases" / "contact_models")]}))
    project = {"targets": targets, "home": tmp_path / "home"}
    result = harness(project, "bisect", "dem", "good", "HEAD", "-k", "oblique", "-j", "2", timeout=1500)
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"first bad commit: {broken}" in result.stdout
    assert "halve the tangential damping" in result.stdout


def test_speed_detector_marks_a_step_and_ignores_noise():
    from harness.analysis.regressions import speed_changes

    noisy = [1.0, 1.04, 0.97, 1.02, 0.99, 1.03, 0.98]
    assert speed_changes(noisy) == []
    stepped = noisy + [1.5, 1.52]
    marked = speed_changes(stepped)
    assert [i for i, _ in marked] == [7] and marked[0][1] == pytest.approx(1.5 / (sum(noisy[2:7]) / 5))


def test_a_speed_change_inside_the_spread_of_repeated_runs_is_not_marked():
    from harness.analysis.regressions import speed_changes
    from harness.store.rules import relative_spread

    times = [1.0, 1.0, 1.0, 1.0, 1.0, 1.3]
    assert [i for i, _ in speed_changes(times)] == [5]                         # no repeats: a 30 % step
    assert speed_changes(times, spreads=[0.0] * 5 + [0.4]) == []               # its repeats spread 40 %
    assert speed_changes(times, spreads=[0.4] + [0.0] * 5) == []               # a build before spread 40 %
    assert [i for i, _ in speed_changes(times, spreads=[0.1] * 6)] == [5]      # 30 % beyond a 10 % spread
    assert relative_spread({"stepping_repeats": [1.0, 1.2, 1.1]}) == pytest.approx(0.2 / 1.1)
    assert relative_spread({"total": 1.0}) == 0.0


def test_regressions_marks_the_commits_where_physics_and_speed_changed(tmp_path, monkeypatch):
    repo = git_repo(tmp_path / "repo")
    # a history is ordered by commit date: one commit a day, as in a real history (GitPython reads these)
    day = iter(range(1, 20))

    def commit_daily(*args, **kwargs):
        date = f"2026-01-{next(day):02d}T12:00:00"
        monkeypatch.setenv("GIT_AUTHOR_DATE", date)
        monkeypatch.setenv("GIT_COMMITTER_DATE", date)
        return commit_files(*args, **kwargs)

    source = fake_engine_source(9.81)
    commits = [commit_daily(repo, {"engine/__init__.py": "", "engine/__main__.py": source,
                                   "cases/fall/scene.json": scene(1.0, steps=100),
                                   "cases/fall/run.config": json.dumps({"runs": [{"name": "drop",
                                                                                  "script": "scene.json"}]})},
                            "start", tag="first")]
    for i in range(1, 8):
        files = {"NOTES.txt": f"{i}\n"}
        if i == 4:   # physics: gravity 10 % larger from here on
            source = fake_engine_source(9.81 * 1.1)
            files["engine/__main__.py"] = source
        if i == 6:   # speed: the engine reports twice the loop time from here on
            files["engine/__main__.py"] = fake_engine_source(9.81 * 1.1, stepping=[0.004])
        commits.append(commit_daily(repo, files, f"change {i}"))
    targets = tmp_path / "targets"
    targets.mkdir()
    write_target(targets, "t", revision="HEAD", repo=repo)
    project = {"targets": targets, "home": tmp_path / "home"}
    _ok(harness(project, "run", "t@first..HEAD", "-j", "2"))
    _ok(harness(project, "run", "t@first"))
    changes = json.loads(_ok(harness(project, "regressions", "t", "--json")).stdout)
    marked = {(c["commit"], c["kind"]) for c in changes}
    assert marked == {(commits[4], "quantity"), (commits[6], "slower")}
    quantity = next(c for c in changes if c["kind"] == "quantity")
    assert quantity["previous_commit"] == commits[3] and "ke C = " in quantity["detail"]
