"""Multisphere clumps in the bundled engine and in LIGGGHTS' multisphere model, through the harness.

``harness run liggghts-shapes dem-shapes -k testcases/shapes/crosscode_*`` runs the dumbbell bounce and the
settling pile of 200 dumbbells in both codes; ``harness check dem-shapes`` scores the engine against LIGGGHTS
(docs/shapes.md): the bounce row by row, the pile within bands from the seed spread of LIGGGHTS' packings.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from crosscode_testing import harness, records
from test_scenes_crosscode import post_script_env

needs_liggghts = pytest.mark.skipif(not Path("/usr/bin/liggghts").exists(), reason="LIGGGHTS not installed")


@pytest.fixture(scope="module")
def shapes(tmp_path_factory):
    home = tmp_path_factory.mktemp("home")
    env = post_script_env(tmp_path_factory.mktemp("userbase"))
    pattern = "testcases/shapes/crosscode_*"
    harness(home, "run", "liggghts-shapes", "dem-shapes", "-k", pattern, "-j", "1", env=env)
    check = harness(home, "check", "dem-shapes", "-k", pattern, "--json", check=False, env=env)
    return records(home, "dem-shapes"), records(home, "liggghts-shapes"), check


@needs_liggghts
@pytest.mark.liggghts
@pytest.mark.slow
class TestClumpsAgainstLiggghts:
    def test_every_run_met_its_expectations(self, shapes):
        engine, reference, _ = shapes
        assert len(engine) == len(reference) == 5
        for record in list(engine.values()) + list(reference.values()):
            assert record["state"] == "post_processed", record["failure_message"]

    def test_bounce_energy_agrees_to_1e_4(self, shapes):
        for name in ("e0.5", "e1"):
            values = []
            for found in shapes[:2]:
                folder = Path(found[f"testcases/shapes/crosscode_dumbbell/{name}"]["folder"])
                values.append(float((folder / "post" / "bounce.csv").read_text().splitlines()[-1].split(",")[1]))
            assert values[0] == pytest.approx(values[1], rel=1e-4)

    def test_check_verdicts(self, shapes):
        check = shapes[2]
        assert check.returncode == 0, check.stdout + check.stderr
        verdicts = {v["run"]: v for v in json.loads(check.stdout)}
        for name in ("e0.5", "e1"):
            assert verdicts[name]["consistency"] == "perfect", verdicts[name]
        for name in ("seed_a", "seed_b", "seed_c"):
            assert verdicts[name]["status"] == "passed", verdicts[name]
            assert verdicts[name]["consistency"] in ("perfect", "good"), verdicts[name]
