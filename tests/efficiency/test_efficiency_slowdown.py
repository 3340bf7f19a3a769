"""A planted slowdown is found by ``harness bisect --slower`` and explained: a busy loop in one function of a
small real C++ code (its profile diff names the function, its breakdown the section), and one in a phase of
the bundled engine (its breakdown names the phase). All through the real CLI, real git, make, g++ and perf."""
import json
import re
import subprocess
from pathlib import Path

import pytest
from efficiency_support import ROOT, commit_files, git_repo, harness, make_code_project, rows

pytestmark = pytest.mark.skipif(subprocess.run(["which", "perf", "g++"], capture_output=True).returncode != 0,
                                reason="needs perf and g++ (scripts/setup.sh installs them)")


def _ok(result):
    assert result.returncode == 0, result.stdout + result.stderr
    return result


def table_after(text: str, heading: str) -> list[list[str]]:
    """The rows (split on blanks) of the indented table after the line containing ``heading``."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if heading in line)
    out = []
    for line in lines[start + 2:]:
        if not line.startswith("  "):
            break
        out.append(line.split())
    return out


def test_bisect_slower_names_the_function_with_the_planted_busy_loop(tmp_path):
    project = make_code_project(tmp_path, commits=6, slow_at=3)
    result = _ok(harness(project, "bisect", "mini", "good", "HEAD", "--slower", "1.5", timeout=900))
    out = result.stdout
    assert f"first bad commit: {project['commits'][3]}" in out and "change 3 (pair forces)" in out
    assert "where the time went" in out
    # the breakdown: the pair section grew most and explains most of the growth of the loop time
    assert "breakdown (grew most: pair)" in out
    sections = table_after(out, "breakdown (grew most")
    assert sections[0][0] == "pair" and float(sections[0][3]) > 0
    # the profile: compute_pair_forces' share grew most, and the others' shares did not grow
    assert "profile (share grew most: compute_pair_forces)" in out
    functions = table_after(out, "profile (share grew most")
    assert functions[0][-1] == "compute_pair_forces"
    grown = {row[-1]: float(row[2].rstrip("%")) for row in functions}
    assert grown["compute_pair_forces"] > 20  # percentage points of all samples
    assert all(v <= grown["compute_pair_forces"] / 4 for k, v in grown.items() if k != "compute_pair_forces")
    # the profiles are kept in the run folders, named in the store
    profiled = rows(project, "SELECT folder, profile FROM harness_run WHERE profile != ''")
    assert profiled and all((tmp_path / "home").exists() for _ in profiled)
    for folder, name in profiled:
        text = (ROOT / folder / name).read_text() if not folder.startswith("/") else open(f"{folder}/{name}").read()
        assert re.search(r"^mini;.*compute_pair_forces \d+$", text, re.M)


def test_compare_profile_prints_the_functions_whose_share_grew(tmp_path):
    project = make_code_project(tmp_path, commits=2, slow_at=1, profile=False)
    good = project["commits"][0]
    result = harness(project, "compare", f"mini@{good}", "mini@HEAD", "--profile", timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr   # slower, not inconsistent
    out = result.stdout
    assert "profile (share grew most: compute_pair_forces)" in out
    data = json.loads(_ok(harness(project, "compare", f"mini@{good}", "mini@HEAD", "--profile", "--json",
                                  "--no-run")).stdout)
    explained = data["profiles"][0]
    assert explained["functions"][0]["function"] == "compute_pair_forces"
    assert explained["sections"][0]["section"] == "pair"
    assert explained["time_ratio"] > 1.5


@pytest.mark.slow
def test_bisect_slower_names_the_engine_phase_with_the_planted_busy_loop(tmp_path):
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    subprocess.run(["git", "-C", str(clone), "tag", "good"], check=True)
    repo = git_repo(clone)
    output = clone / "engine" / "output.py"
    text = output.read_text()
    anchor = '        sim.timing["output"] += time.perf_counter() - t0\n'
    assert anchor in text, "the output timer line moved: update the planted change"
    # 20 ms of busy waiting in every output (thermo rows, dumps): the output phase of the step loop
    busy = ("        spin_until = time.perf_counter() + 0.02\n"
            "        while time.perf_counter() < spin_until:\n            pass\n")
    commit_files(repo, {"NOTES.txt": "unrelated\n"}, "docs only")
    slow = commit_files(repo, {"engine/output.py": text.replace(anchor, busy + anchor, 1)}, "wait in every output")
    commit_files(repo, {"NOTES.txt": "unrelated again\n"}, "docs only again")
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "dem.json").write_text(json.dumps({"repository": str(clone), "revision": "HEAD",
                                                  "testcases": [str(ROOT / "testcases" / "analytic")]}))
    project = {"targets": targets, "home": tmp_path / "home"}
    result = harness(project, "bisect", "dem", "good", "HEAD", "-k", "free_fall/dt1e-4", "--slower", "2",
                     "--profile", timeout=1500)
    assert result.returncode == 0, result.stdout + result.stderr
    out = result.stdout
    assert f"first bad commit: {slow}" in out and "wait in every output" in out
    assert "breakdown (grew most: output)" in out
    sections = table_after(out, "breakdown (grew most")
    # 21 thermo rows (2,000 steps, every 100) of 20 ms each: the slow commit's output phase holds at least 0.42 s.
    # Its growth over the good commit is that less the good commit's own output time (a few ms, which varies).
    section, before, after, growth = sections[0][:4]
    assert section == "output" and float(after) >= 0.42 and float(growth) >= 0.42 - 0.05
    # the engine's profile is its phase timers: the output phase's share grew most
    assert "profile (share grew most: output)" in out


def test_gc_collects_the_raw_samples_of_old_builds_and_keeps_folded_stacks(tmp_path):
    project = make_code_project(tmp_path, commits=1, slow_at=5, profile=False)
    _ok(harness(project, "run", "mini@good", "--profile"))
    _ok(harness(project, "run", "mini", "--profile"))
    profiled = dict(rows(project, "SELECT b.current, r.folder FROM harness_run r JOIN harness_build b "
                                  "ON r.build_id = b.id WHERE r.profile = 'profile.folded'"))
    old, current = Path(profiled[0]), Path(profiled[1])
    assert (old / "perf.data").is_file() and (current / "perf.data").is_file()
    listed = _ok(harness(project, "gc", "--dry-run")).stdout
    assert f"would remove {old / 'perf.data'}" in listed and str(current / "perf.data") not in listed
    assert (old / "perf.data").is_file()
    _ok(harness(project, "gc"))
    assert not (old / "perf.data").exists() and (old / "profile.folded").is_file()  # --keep-builds 2 keeps old/
    assert (current / "perf.data").is_file() and (current / "profile.folded").is_file()
