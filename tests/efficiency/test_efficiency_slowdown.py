"""A planted slowdown is found by ``harness bisect --slower`` and explained: a busy loop in one function of a
small real C++ code (its profile diff names the function, its breakdown the section), and one in a phase of
the bundled engine (its breakdown names the phase). All through the real CLI, real git, make, g++ and perf."""
import json
import re
import subprocess

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
