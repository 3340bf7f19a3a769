"""The LIGGGHTS settling case scales from 1 to 2 MPI ranks (``harness scaling``), with the speedup LIGGGHTS
itself reports: the ratio of its own ``Loop time of T on P procs`` lines; efficiency, Karp-Flatt serial fraction
and the particle imbalance follow from LIGGGHTS' numbers by their formulas."""
from __future__ import annotations

import json
import re

import pytest

from liggghts_support import harness, needs_liggghts, needs_mpirun

pytestmark = [needs_liggghts, needs_mpirun, pytest.mark.liggghts, pytest.mark.slow]
LOOP = re.compile(r"^Loop time of (\S+) on (\d+) procs for (\d+) steps", re.M)
NLOCAL = re.compile(r"^Nlocal:\s+(\S+) ave (\S+) max", re.M)


def test_liggghts_settling_scales_with_the_speedup_liggghts_reports(tmp_path):
    home = tmp_path / "home"
    result = harness(home, "scaling", "liggghts", "-k", "settling")
    out = result.stdout
    assert "testcases/liggghts/settling/scaling  (strong scaling over MPI ranks)" in out
    table = json.loads((home / "scaling" / "testbox" / "liggghts" / "testcases" / "liggghts" / "settling"
                        / "scaling.json").read_text())
    points = {p["cores"]: p for p in table["points"]}
    assert sorted(points) == [1, 2] and all(p["state"] == "post_processed" for p in points.values())
    # independently: LIGGGHTS' own loop times and particles per rank, from the logs of the two runs
    loops, imbalance = {}, {}
    for folder in (home / "runs" / "testbox" / "liggghts").rglob("scaling@cores=*"):
        log = (folder / "log.liggghts").read_text()
        (seconds, procs, steps), = LOOP.findall(log)
        assert steps == "15000" and folder.name.startswith(f"scaling@cores={procs}.")
        loops[int(procs)] = float(seconds)
        (avg, top), = NLOCAL.findall(log)
        imbalance[int(procs)] = float(top) / float(avg)
    speedup = loops[1] / loops[2]
    assert points[1]["time"] == pytest.approx(loops[1], rel=1e-12)
    assert points[2]["speedup"] == pytest.approx(speedup, rel=1e-12)
    assert points[2]["efficiency"] == pytest.approx(speedup / 2, rel=1e-12)
    assert points[2]["serial_fraction"] == pytest.approx((1 / speedup - 1 / 2) / (1 - 1 / 2), rel=1e-9)
    assert points[1]["serial_fraction"] is None and points[1]["speedup"] == 1.0
    assert points[2]["imbalance"] == pytest.approx(imbalance[2]) and points[1]["imbalance"] == 1.0
    # the CLI table says the same
    row = next(line.split() for line in out.splitlines() if line.startswith("2 "))
    assert row[2] == f"{speedup:.3f}"
