"""Helpers for the cross-code tests: the harness CLI in a throw-away workspace, run records, needs-markers."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

PROJECT = Path(__file__).resolve().parents[2]
CODES = {"liggghts": "/usr/bin/liggghts", "lammps": "/usr/bin/lmp", "yade": "/usr/bin/yade"}
needs_codes = pytest.mark.skipif(not all(Path(p).exists() for p in CODES.values()),
                                 reason="needs Debian liggghts, lammps and yade (bash scripts/setup.sh)")
needs_lammps = pytest.mark.skipif(not Path(CODES["lammps"]).exists(), reason="LAMMPS not installed")


def harness(home: Path, *args: str, targets: Path | None = None, check: bool = True, env: dict | None = None):
    cmd = [sys.executable, "-m", "harness.cli", "--machine", "testbox", "--home", str(home)]
    if targets is not None:
        cmd += ["--targets", str(targets)]
    result = subprocess.run(cmd + list(args), cwd=PROJECT, capture_output=True, text=True, errors="replace",
                            timeout=900, env=env)
    if check:
        assert result.returncode == 0, result.stdout + result.stderr
    return result


def records(home: Path, target: str) -> dict[str, dict]:
    """The newest run.json record per 'test case/run' of a target."""
    found = {}
    for path in sorted((home / "runs" / "testbox" / target).rglob("run.json"), key=lambda p: p.stat().st_mtime):
        record = json.loads(path.read_text())
        found[f"{record['testcase']}/{record['run']}"] = record
    return found


def series(record: dict, kind: str) -> dict:
    return next(s for s in record["series"] if s["kind"] == kind)["columns"]


def impact(record: dict) -> tuple[float, float]:
    """(contact time s, restitution) the scene's post script wrote."""
    words = (Path(record["folder"]) / "impact.txt").read_text().split()
    return float(words[2]), float(words[3])
