"""Helpers for the cross-code tests: the harness CLI in a throw-away workspace, run records, needs-markers."""
from __future__ import annotations

from pathlib import Path

import harness_process
import pytest
from harness_process import PROJECT, records, series  # noqa: F401  (the cross-code tests import them from here)

CODES = {"liggghts": "/usr/bin/liggghts", "lammps": "/usr/bin/lmp", "yade": "/usr/bin/yade"}
needs_codes = pytest.mark.skipif(not all(Path(p).exists() for p in CODES.values()),
                                 reason="needs Debian liggghts, lammps and yade (bash scripts/setup.sh)")
needs_lammps = pytest.mark.skipif(not Path(CODES["lammps"]).exists(), reason="LAMMPS not installed")


def harness(home: Path, *args: str, targets: Path | None = None, check: bool = True, env: dict | None = None):
    """``harness_process.harness`` with the longer time limit of cross-code runs (three codes per test case)."""
    return harness_process.harness(home, *args, targets=targets, check=check, env=env, timeout=900)


def impact(record: dict) -> tuple[float, float]:
    """(contact time s, restitution) the scene's post script wrote."""
    words = (Path(record["folder"]) / "impact.txt").read_text().split()
    return float(words[2]), float(words[3])
