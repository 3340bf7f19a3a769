"""The interface every engine adapter implements.

The harness runs an engine as a program in a fresh run folder and learns everything from the
files the program leaves there: a log, thermo output, a timing breakdown, VTK dumps.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


class UserError(Exception):
    """An error the user can fix (bad input file, unknown name): shown as one line, never a traceback."""


@dataclass
class LogScan:
    """What an adapter found in a run's log: ``ERROR:`` lines fail a run even with exit code 0."""

    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


class EngineAdapter:
    """Base class; subclasses set ``name`` and implement the methods below."""

    name = ""
    #: required thermo columns after the adapter's mapping (thesis 4.4.1)
    required_thermo = ("step", "atoms", "ke", "rke")

    def command(self, executable: list[str], script: str, variables: dict[str, str], log: str,
                mpi: list[str] | None = None) -> list[str]:
        """Command line that runs ``script`` (relative to the run folder) with ``-var`` values.

        ``mpi`` is the launcher prefix (e.g. ``["mpirun", "-np", "4"]``) for mpi runs, else None.
        """
        raise NotImplementedError

    def log_file(self) -> str:
        """Name of the log file the harness asks the engine to write in the run folder."""
        return "log.txt"

    def read_thermo(self, folder: Path, mapping: dict[str, str] | None = None):
        """Thermo output of a run as a pandas DataFrame with at least ``required_thermo`` columns."""
        raise NotImplementedError

    def read_timing(self, folder: Path) -> dict[str, float]:
        """Timing breakdown in s: pair, neigh, comm, modify, output, other, total (missing ones 0)."""
        raise NotImplementedError

    def scan_log(self, folder: Path) -> LogScan:
        raise NotImplementedError

    def vtk_files(self, folder: Path) -> list[Path]:
        """VTK dumps the run wrote, in output order."""
        raise NotImplementedError

    def default_run_config(self, folder: Path) -> dict | None:
        """A run.config for a test case folder that has none, or None if the folder is not a test case."""
        return None
