"""Reading a run folder for the dashboard: the input script, log, console output, artifacts.

Every path a request names is resolved and must stay inside the run folder (no ``../``, no symlink out).
File names come from where they are decided: the engine's log from the adapter of the run's target
(``harness.adapters``), console output and post script log from ``harness.execution.execute``.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

from django.conf import settings

from harness.adapters import UserError, get_adapter
from harness.execution.execute import POST_LOG, RECORD_FILE, STDERR, STDOUT

#: the adapter of a target whose definition names none (harness/config/targets.py: ``engine`` defaults to dem)
DEFAULT_ENGINE = "dem"
SCRIPT_KEYS = ("script", "input", "input_script")
RECORD_NAME = RECORD_FILE
#: files looked at when listing artifacts, at most (a run folder with a million dumps lists the first ones)
ARTIFACT_SCAN_LIMIT = 20_000
#: artifact suffixes offered for download on the run page
ARTIFACT_SUFFIXES = (".vtp", ".vtk", ".vtu", ".csv", ".txt", ".json", ".xml", ".dat", ".log", ".in")


def _natural(path: Path):
    # dump_500.vtk before dump_1000.vtk
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", path.as_posix())]


@dataclass
class TextFile:
    """A text shown on a page: ``name`` relative to the run folder, ``text`` possibly cut at ``limit``."""

    name: str
    text: str
    truncated: bool = False


class RunFolder:
    """The files of one run on disk (``Run.folder``); missing folders read as empty."""

    def __init__(self, run):
        self.run = run
        self.root = Path(run.folder).resolve() if run.folder else None

    def exists(self) -> bool:
        return self.root is not None and self.root.is_dir()

    def resolve(self, relative: str) -> Path | None:
        """Path of ``relative`` inside the run folder, or None if it leaves the folder or is no file."""
        if not self.exists() or not relative or "\x00" in relative:
            return None
        try:
            candidate = (self.root / relative).resolve()
            if not candidate.is_relative_to(self.root) or not candidate.is_file():
                return None
        except OSError:  # a name too long for the file system, a symlink loop: no such file
            return None
        return candidate

    def log_name(self) -> str | None:
        """The log file the engine adapter of the run's target writes (None: adapter unknown here)."""
        target = getattr(self.run, "target", None)
        definition = getattr(target, "definition", None)
        engine = (definition.get("engine") if isinstance(definition, dict) else None) or DEFAULT_ENGINE
        try:
            return get_adapter(engine).log_file()
        except UserError:  # a run imported from a machine with an adapter this one lacks
            return None

    def _first(self, names) -> str | None:
        for name in names:
            if name and self.resolve(name):
                return name
        return None

    def read(self, relative: str | None, limit: int | None = None) -> TextFile | None:
        """Text of a file in the run folder (undecodable bytes replaced), cut at ``limit`` bytes."""
        path = self.resolve(relative) if relative else None
        if path is None:
            return None
        limit = limit or settings.DASHBOARD_TEXT_LIMIT
        with path.open("rb") as fh:
            data = fh.read(limit + 1)
        return TextFile(relative, data[:limit].decode("utf-8", "replace"), len(data) > limit)

    def script_name(self) -> str | None:
        config = self.run.config if isinstance(self.run.config, dict) else {}
        names = []
        for key in SCRIPT_KEYS:
            value = config.get(key)
            # a script per engine family ({"dem": "scene.json", "liggghts": "in.scene"}): the one present
            names += [value] if isinstance(value, str) else [v for v in value.values() if isinstance(v, str)] \
                if isinstance(value, dict) else []
        found = self._first(names)
        if found or not self.exists():
            return found
        # Fall back on the usual input script names of LAMMPS-family codes and the bundled engine.
        for pattern in ("in.*", "*.in", "*.dem.json", "scene*.json"):
            for path in sorted(self.root.glob(pattern)):
                if path.is_file() and path.name != RECORD_NAME:
                    return path.name
        return None

    def texts(self) -> dict[str, TextFile | None]:
        """The texts the run page and the comparison show, by section."""
        return {
            "input script": self.read(self.script_name()),
            "run configuration": TextFile("run.config entry", json.dumps(self.run.config, indent=2,
                                                                           sort_keys=True)),
            "run record": self.read(RECORD_NAME),
            "log": self.read(self.log_name()),
            "stdout": self.read(STDOUT),
            "stderr": self.read(STDERR),
            "post scripts": self.read(POST_LOG),
        }

    def artifacts(self, limit: int = 500) -> list[tuple[str, int]]:
        """(relative path, size in bytes) of downloadable files, at most ``limit``, sorted by path."""
        if not self.exists():
            return []
        found: list[tuple[str, int]] = []
        scanned = 0
        log_name = self.log_name()

        def wanted(path: Path) -> bool:
            # the engine's log has the adapter's name, whatever its suffix (log.dem, log.liggghts)
            return path.suffix.lower() in ARTIFACT_SUFFIXES or path.name == log_name

        # depth first, each folder's entries in natural order: the order of the sorted relative paths, and
        # it stops after ``limit`` artifacts instead of listing the whole tree first
        def walk(folder: Path) -> None:
            nonlocal scanned
            try:
                entries = sorted(folder.iterdir(), key=_natural)
            except OSError:
                return
            for path in entries:
                scanned += 1
                if len(found) >= limit or scanned > ARTIFACT_SCAN_LIMIT:
                    return
                if path.is_symlink():
                    if path.is_file() and path.resolve().is_relative_to(self.root) and wanted(path):
                        found.append((path.relative_to(self.root).as_posix(), path.stat().st_size))
                elif path.is_dir():
                    walk(path)
                elif path.is_file() and wanted(path):
                    found.append((path.relative_to(self.root).as_posix(), path.stat().st_size))

        walk(self.root)
        return found
