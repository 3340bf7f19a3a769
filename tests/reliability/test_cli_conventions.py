"""CLI conventions and the one-command CI job, through the real CLI on the fake engine's project."""
import json
import xml.etree.ElementTree as ET

from provenance_support import harness, make_project, write_target


def test_ci_in_one_command_and_cli_conventions(tmp_path):
    project = make_project(tmp_path)
    junit = tmp_path / "junit.xml"
    ci = harness(project, "ci", "dev", "--junit", str(junit), "-j", "2")
    assert ci.returncode == 0, ci.stdout + ci.stderr
    assert "ci: 8 runs executed (0 failed)" in ci.stdout and "4 checked: 4 passed" in ci.stdout
    # one line per run as it starts, with the elapsed time (and, once runs finished, what is left)
    starts = [line for line in ci.stderr.splitlines() if line.startswith("start ")]
    assert len(starts) == 8 and "elapsed" in starts[0] and "left)" in starts[-1]
    # the reference's runs are not tests of the target under test
    assert {c.get("classname").split(".")[0] for c in ET.parse(junit).getroot().iter("testcase")} == {"dev"}
    # a broken revision: one exit code, 1
    write_target(project["targets"], "dev", revision="v2", repo=project["repo"], reference="ref")
    assert harness(project, "ci", "dev", "--junit", str(junit)).returncode == 1
    write_target(project["targets"], "dev", revision="v1", repo=project["repo"], reference="ref")
    # exit code 5 when a selection matches nothing, as pytest
    assert harness(project, "run", "dev", "-k", "no-such-run").returncode == 5
    assert harness(project, "check", "dev", "-k", "no-such-run").returncode == 5
    assert harness(project, "list", "dev", "-k", "no-such-run").returncode == 5
    # JSON on list, status, check; global options after the subcommand; -q shows failures only
    listing = json.loads(harness(project, "list", "dev", "--json").stdout)
    assert len(listing) == 4 and {r["state"] for r in listing} == {"consistency_checked"}
    status = json.loads(harness(project, "status", "--json").stdout)
    assert {s["target"]: s["commit"] for s in status} == {"dev": project["v1"], "ref": project["v1"]}
    check = harness(project, "check", "dev", "--json", "--machine", "m1")
    assert check.returncode == 0 and len(json.loads(check.stdout)) == 4
    assert harness(project, "check", "dev", "-q").stdout.startswith("4 runs: 4 passed")
    # unknown target or state: one line
    for args in (("list", "--state", "passed"), ("list", "nosuch"), ("run", "nosuch")):
        result = harness(project, *args)
        assert result.returncode == 1 and result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    version = harness(project, "--version")
    assert version.returncode == 0 and version.stdout.startswith("harness ")
