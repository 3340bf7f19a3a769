"""The test case collection (testcases/) through the harness, as CI runs it: run, check, sweep.

Every run of the bundled engine target must pass its expectations and stability checks and be consistent with
the pinned reference target; the sweeps must show Velocity-Verlet's second order.
"""
import xml.etree.ElementTree as ET

import harness_process
import pandas as pd
import pytest

from harness.execution.workspace import PROJECT_ROOT

# the whole collection, about 200 runs: 4-5 minutes on two cores with the kernels to compile
pytestmark = pytest.mark.slow


def harness(home, *args, timeout=1500):
    return harness_process.harness(home, *args, machine="ci", check=False, timeout=timeout)


@pytest.fixture(scope="module")
def collection(tmp_path_factory):
    if not (PROJECT_ROOT / ".git").exists():
        pytest.skip("needs the project's git checkout (targets are built from git)")
    home = tmp_path_factory.mktemp("collection-home")
    run = harness(home, "run", "dem", "-j", "2")
    junit = home / "junit.xml"
    check = harness(home, "check", "dem", "--junit", str(junit))
    sweep = harness(home, "sweep", "dem", "--no-run")
    return home, run, check, junit, sweep


def test_every_run_of_the_collection_passes(collection):
    _, run, _, _, _ = collection
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-4000:]
    assert " failed" not in run.stdout.split("runs:")[-1].split(",")[1] or ", 0 failed" in run.stdout


def test_collection_is_consistent_with_the_reference(collection):
    _, _, check, junit, _ = collection
    assert check.returncode == 0, check.stdout[-4000:] + check.stderr[-4000:]
    tree = ET.parse(junit)
    cases = tree.getroot().findall(".//testcase")
    names = {c.get("classname", "") + "/" + c.get("name", "") for c in cases}
    # the folders by theme are all there, with their runs
    for folder in ("analytic", "contact_models", "walls", "insertion", "stability", "accuracy", "effects"):
        assert any(f"testcases/{folder}/" in n or f"testcases.{folder}" in n for n in names), folder
    assert len(cases) >= 40
    assert not tree.getroot().findall(".//failure") and not tree.getroot().findall(".//error")


def test_sweeps_show_second_order_in_the_time_step(collection):
    home, _, _, _, sweep = collection
    assert sweep.returncode == 0, sweep.stdout[-3000:] + sweep.stderr[-3000:]
    table = pd.read_csv(next(home.glob("sweeps/ci/dem/testcases/accuracy/oscillator/dt.csv")))
    assert list(table["value"]) == sorted(table["value"], reverse=True)
    from harness.config.sweep import observed_order

    order = observed_order(table["value"], table["error"])
    assert 1.8 < order < 2.3, table
    assert (table["run_time"] > 0).all()
    assert (home / "sweeps/ci/dem/testcases/accuracy/oscillator/dt.png").stat().st_size > 10_000
    bulk = pd.read_csv(home / "sweeps/ci/dem/testcases/accuracy/settling_bed/dt.csv")
    assert len(bulk) == 4 and bulk["error"].iloc[:-1].notna().all()
    assert "observed order" in sweep.stdout
