"""Adapter for the bundled engine (``python -m engine`` / ``dem``), after its program contract.

Command line ``-in SCRIPT -var NAME VALUE ... -log FILE`` run in the run folder; thermo in ``thermo.csv``
(``step,time,atoms,ke,rke,...``), timing in ``timing.json``, ``ERROR:``/``WARNING:`` lines in the log,
VTK PolyData dumps ``post/<prefix>_<step>.vtp``.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pandas as pd

from harness.adapters import register
from harness.adapters.base import EngineAdapter, LogScan, LoopBlock, UserError
from harness.config.acceptance import blowup_limit
from harness.execution.postprocess import dump_step

TIMING_KEYS = ("pair", "neigh", "comm", "modify", "output", "other", "total")
#: the engine's line after each run block (engine/runner.py): loop time, steps, particles, its rates
#: (older engines print less of it: everything after the step count is optional)
LOOP_TIME = re.compile(r"Loop time of (\S+) s for (\d+) steps(?: with (\d+) particles)?(?: \((\S+) particle-steps/s\))?"
                       r"(?:.*\((\S+) particle-steps per cpu second\))?")


def read_text(path: Path) -> str:
    """A text file as str; bytes that are not UTF-8 become U+FFFD (engines may write anything)."""
    return path.read_text(encoding="utf-8", errors="replace")


def scan_lines(text: str) -> LogScan:
    scan = LogScan()
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("ERROR"):
            scan.errors.append(stripped)
        elif stripped.startswith("WARNING"):
            scan.warnings.append(stripped)
    return scan


@register
class DemAdapter(EngineAdapter):
    name = "dem"
    first_run_note = ("the engine compiles its kernels first (up to a minute for each new combination of "
                      "contact models); later runs reuse them")
    #: more cores are more Numba threads (NUMBA_NUM_THREADS); its profile is its own phase timers (engine/runner.py)
    parallelism = "threads"
    profiler = "phases"
    thermo_file = "thermo.csv"
    timing_file = "timing.json"

    def log_file(self) -> str:
        return "log.dem"

    def accepts_script(self, script: str) -> bool:
        """The engine reads JSON command lists; a run.config whose plain ``script`` is e.g. a LIGGGHTS
        ``in.*`` file is not for this engine (name both with ``{"dem": ..., "liggghts": ...}``)."""
        return script.endswith(".json")

    def read_thermo(self, folder: Path, mapping=None) -> pd.DataFrame:
        path = Path(folder) / self.thermo_file
        if not path.is_file():
            raise UserError(f"no thermo output: {self.thermo_file} missing")
        try:
            frame = pd.read_csv(path, skipinitialspace=True, encoding_errors="replace")
        except (pd.errors.EmptyDataError, pd.errors.ParserError) as exc:
            raise UserError(f"{self.thermo_file}: unreadable ({str(exc).splitlines()[0]})") from None
        frame.columns = [str(c).strip() for c in frame.columns]
        if frame.empty:
            raise UserError(f"{self.thermo_file}: header only, no thermo rows")
        return self.map_thermo(frame, mapping, self.thermo_file)

    def read_timing(self, folder: Path) -> dict[str, float]:
        path = Path(folder) / self.timing_file
        try:
            data = json.loads(read_text(path))
        except (OSError, ValueError):
            return {}
        if not isinstance(data, dict):
            return {}
        timing = {}
        for key, value in data.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
                timing[key] = float(value)
        for key in TIMING_KEYS:
            timing.setdefault(key, 0.0)
        return timing

    def scan_log(self, folder: Path) -> LogScan:
        path = Path(folder) / self.log_file()
        return scan_lines(read_text(path)) if path.is_file() else LogScan()

    def loop_blocks(self, folder: Path) -> list[LoopBlock]:
        """From the engine's ``Loop time of T s for N steps with P particles (R particle-steps/s) ...`` lines."""
        path = Path(folder) / self.log_file()
        text = read_text(path) if path.is_file() else ""
        return [LoopBlock(seconds=float(m.group(1)), steps=int(m.group(2)),
                          particles=int(m.group(3)) if m.group(3) else None,
                          rate=float(m.group(4)) if m.group(4) else None,
                          cpu_rate=float(m.group(5)) if m.group(5) else None)
                for m in LOOP_TIME.finditer(text)]

    def largest_overlaps(self, folder: Path) -> list[float]:
        """From the engine's ``Loop time ...; max overlap X% of radius`` line of each run block."""
        path = Path(folder) / self.log_file()
        text = read_text(path) if path.is_file() else ""
        return [float(m) / 100.0 for m in re.findall(r"; max overlap ([0-9.eE+-]+)% of radius", text)]

    def run_environment(self, config: dict) -> dict[str, str]:
        """The run configuration's ``stability.blowup`` for the engine's own blow-up check (engine/blowup.py):
        ``false`` switches it off, ``{"max_overlap": X}`` sets the limit."""

        limit = blowup_limit(config)
        if limit is None:
            return {}
        return {"DEM_BLOWUP_MAX_OVERLAP": "off" if limit == math.inf else repr(float(limit))}

    def vtk_files(self, folder: Path) -> list[Path]:

        files = [p for p in (Path(folder) / "post").rglob("*.vtp")] if (Path(folder) / "post").is_dir() else []
        return sorted(files, key=lambda p: (p.parent.as_posix(), dump_step(p) or 0, p.name))
