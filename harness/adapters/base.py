"""The interface every engine adapter implements.

The harness runs an engine as a program in a fresh run folder and learns everything from the
files the program leaves there: a log, thermo output, a timing breakdown, VTK dumps.
"""
from __future__ import annotations

import functools
import os
import re
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

from harness.analysis.breakdown import from_timing


class UserError(Exception):
    """An error the user can fix (bad input file, unknown name): shown as one line, never a traceback."""


@dataclass
class LogScan:
    """What an adapter found in a run's log: ``ERROR:`` lines fail a run even with exit code 0."""

    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


@dataclass
class LoopBlock:
    """One run block's stepping as the code's log reports it: its loop time in s (no start-up, no JIT
    compilation), steps, particles at its end, MPI ranks, and - where the code prints them - its own
    particle-steps per second and per CPU second. The benchmarks read loop times through ``loop_blocks``."""

    seconds: float
    steps: int
    particles: int | None = None
    ranks: int = 1
    rate: float | None = None
    cpu_rate: float | None = None

    @property
    def particle_steps_per_s(self) -> float | None:
        """The code's own rate when it prints one, else steps x particles / loop time."""
        if self.rate is not None:
            return self.rate
        if self.particles is None or self.seconds <= 0:
            return None
        return self.steps * self.particles / self.seconds


def find_column(columns, wanted: str) -> str | None:
    """The column of ``columns`` a user or script means by ``wanted``, or None.

    First the exact name, then the name without a LAMMPS-style ``c_``/``v_``/``f_`` prefix on either side
    (LIGGGHTS 3.8 prints ``c_rke`` as ``rke``, LAMMPS keeps ``c_rke``), then case-insensitively.
    """
    columns = [str(c) for c in columns]
    if wanted in columns:
        return wanted
    bare = re.sub(r"^[cvf]_", "", wanted)
    for column in columns:
        if re.sub(r"^[cvf]_", "", column) == bare:
            return column
    lowered = {c.lower(): c for c in columns}
    return lowered.get(wanted.lower()) or lowered.get(bare.lower())


@functools.lru_cache(maxsize=None)
def is_open_mpi(launcher: str) -> bool:
    """Whether the MPI launcher ``launcher`` (a name on PATH or a path) is Open MPI's (its ``--version``)."""
    path = shutil.which(launcher)
    if not path:
        return False
    try:
        out = subprocess.run([path, "--version"], capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return "Open MPI" in (out.stdout + out.stderr) or "OpenRTE" in (out.stdout + out.stderr)


def with_open_mpi_flags(mpi: list[str]) -> list[str]:
    """The launcher prefix ``mpi`` (``["mpirun", "-np", "4"]``) with the flags Open MPI needs in a container,
    added only where needed - the one place they are added (``harness.execution.planning.mpi_prefix`` calls it):

    - ``--allow-run-as-root``: Open MPI refuses to start as root (uid 0, usual in containers and CI);
    - ``--oversubscribe``: Open MPI refuses ``-np`` above the number of cores it detects.

    Flags already present are not repeated; other launchers (MPICH, srun) are left untouched.
    """
    mpi = list(mpi)
    if not mpi or not is_open_mpi(mpi[0]):
        return mpi
    extra = []
    if os.geteuid() == 0 and "--allow-run-as-root" not in mpi:
        extra.append("--allow-run-as-root")
    nprocs = None
    for flag in ("-np", "-n", "--np"):
        if flag in mpi[:-1]:
            value = mpi[mpi.index(flag) + 1]
            nprocs = int(value) if value.isdigit() else None
    if nprocs is not None and nprocs > (os.cpu_count() or 1) and "--oversubscribe" not in mpi:
        extra.append("--oversubscribe")
    return mpi[:1] + extra + mpi[1:]


class EngineAdapter:
    """Base class; subclasses set ``name`` and implement the methods below.

    The contract, everything code-specific in one place (../shared/design.md, "Engines are programs"):

    - ``command``: the command line of one run (by default the LAMMPS-style ``-in``/``-var``/``-log`` contract
      the bundled engine, LIGGGHTS and LAMMPS share); ``log_file``: the log it asks the code to write;
    - ``accepts_script``: whether a plain ``script`` of a run.config is in this code's input language;
    - ``default_thermo_columns`` and ``map_thermo``: the code's names for the harness' thermo columns;
    - ``read_thermo``, ``read_timing``, ``loop_blocks``, ``scan_log``, ``vtk_files``: what a finished run left
      behind;
    - ``default_run_config``: run configurations for a folder without run.config (shipped examples).

    Adapters are found by name (``harness.adapters.get_adapter``): the built-in modules, adapters other
    packages declare in the entry-point group ``dem_harness.adapters``, and ``generic:FILE`` (an adapter
    configured by a JSON file, ``harness.adapters.generic``).
    """

    name = ""
    #: required thermo columns after the adapter's mapping (thesis 4.4.1)
    required_thermo = ("step", "atoms", "ke", "rke")
    #: what the harness prints before the first run of a new build, when the engine spends a while on it
    #: (the bundled engine compiles its kernels); blank: nothing to say
    first_run_note = ""
    #: harness name -> the code's own thermo column name, used when neither target nor run.config maps it
    default_thermo_columns: dict[str, str] = {}
    #: how a scaling study (``harness.analysis.scaling``) gives this code more cores: "mpi" ranks or "threads"
    parallelism = "mpi"
    #: how ``harness run --profile`` samples it: "perf" (``perf record -g`` of a native program) or "phases"
    #: (the code's own phase timers, for an interpreted program whose native stacks say nothing)
    profiler = "perf"

    def accepts_script(self, script: str) -> bool:
        """Whether a run.config's plain ``script`` (not a per-adapter object) is for this code.

        A run.config may name one script for all codes, or ``{"dem": "scene.json", "lammps": "in.scene"}``;
        a plain script in another code's input language is not a run of this code (skipped, not failed).
        """
        return True

    def map_thermo(self, table, mapping: dict[str, str] | None, source: str, candidates: dict | None = None):
        """``table`` (pandas DataFrame in the code's column names) with the harness' columns first.

        For each required column (``required_thermo``) the first match wins: ``mapping`` (``thermo_columns``
        of the target or run.config; a missing column is an error naming it) > ``default_thermo_columns`` >
        ``candidates[key]`` (a list of names, e.g. the IDs of erotate/sphere computes). Columns are matched
        with ``find_column``. ``step`` and ``atoms`` become integers when they have no gaps; every other
        column of the table follows under its own name. Errors are ``UserError`` lines naming ``source``.
        Every adapter maps its thermo through here (the one home of the mapping).
        """
        import pandas as pd  # pandas takes a quarter second to load: not for every `harness` start (UserError)

        columns = [str(c) for c in table.columns]
        table = table.copy()
        table.columns = columns
        chosen: dict[str, str] = {}
        for key in self.required_thermo:
            column = None
            if mapping and key in mapping:
                column = find_column(columns, str(mapping[key]))
                if column is None:
                    raise UserError(f"{source}: thermo_columns.{key} = {mapping[key]!r} is not a thermo column "
                                    f"(columns: {', '.join(columns)})")
            else:
                names = ([self.default_thermo_columns[key]] if key in self.default_thermo_columns else [])
                names += list((candidates or {}).get(key, [])) + [key]
                column = next((c for c in (find_column(columns, n) for n in names) if c), None)
            if column is None:
                raise UserError(f"{source}: no thermo column for {key!r} (columns: {', '.join(columns)}); "
                                f"name it in thermo_columns of the target or run.config")
            chosen[key] = column
        result = pd.DataFrame({key: table[column].to_numpy() for key, column in chosen.items()})
        for key in ("step", "atoms"):
            if key in result and result[key].notna().all():
                result[key] = result[key].astype("int64")
        for column in columns:
            if column not in chosen.values() and column not in result.columns:
                result[column] = table[column].to_numpy()
        return result

    def command(self, executable: list[str], script: str, variables: dict[str, str], log: str,
                mpi: list[str] | None = None) -> list[str]:
        """Command line that runs ``script`` (relative to the run folder) with ``-var`` values:
        ``[MPI PREFIX] EXECUTABLE -in SCRIPT -var NAME VALUE ... -log LOG``.

        ``mpi`` is the launcher prefix (e.g. ``["mpirun", "-np", "4"]``, with its Open MPI flags already
        added by ``harness.execution.planning.mpi_prefix``) for mpi runs, else None.
        """
        command = list(mpi or []) + list(executable) + ["-in", script]
        for name, value in (variables or {}).items():
            command += ["-var", str(name), str(value)]
        return command + ["-log", log]

    def log_file(self) -> str:
        """Name of the log file the harness asks the engine to write in the run folder."""
        return "log.txt"

    def read_thermo(self, folder: Path, mapping: dict[str, str] | None = None):
        """Thermo output of a run as a pandas DataFrame with at least ``required_thermo`` columns."""
        raise NotImplementedError

    def read_timing(self, folder: Path) -> dict[str, float]:
        """Timing breakdown in s: pair, neigh, comm, modify, output, other, total (missing ones 0)."""
        raise NotImplementedError

    def loop_blocks(self, folder: Path) -> list[LoopBlock]:
        """The loop time of each run block the log reports, in order ([]: the code reports none)."""
        return []

    def read_breakdown(self, folder: Path, timing: dict | None = None) -> dict:
        """The timing breakdown in the harness' sections (``harness.analysis.breakdown``): pair, neighbor, communication,
        modify, output, other, with min/avg/max over ranks where the code prints them. By default the
        sections of ``read_timing`` (averages only); codes that print more override it."""

        return from_timing(self.read_timing(folder) if timing is None else timing)

    def scan_log(self, folder: Path) -> LogScan:
        raise NotImplementedError

    def vtk_files(self, folder: Path) -> list[Path]:
        """VTK dumps the run wrote, in output order."""
        raise NotImplementedError

    def largest_overlaps(self, folder: Path) -> list[float]:
        """The largest particle overlap / radius the engine reported, per run block ([]: it reports none);
        the default blow-up check of harness.config.acceptance reads it when thermo has no max_overlap column."""
        return []

    def run_environment(self, config: dict) -> dict[str, str]:
        """Environment variables that pass a run configuration's declarations to the engine (e.g. a relaxed
        blow-up limit); none by default."""
        return {}

    def default_run_config(self, folder: Path) -> dict | None:
        """A run.config for a test case folder that has none, or None if the folder is not a test case."""
        return None
