"""Adapter for LIGGGHTS (CFDEMproject/LIGGGHTS-PUBLIC 3.x, Debian package ``liggghts``).

LIGGGHTS is run as a program from the run folder (its scripts name ``post/`` and ``meshes/`` relative to the
working directory)::

    [mpirun [--allow-run-as-root] [--oversubscribe] -np N] liggghts -in in.scene -var NAME VALUE ... -log log.liggghts

Everything the harness needs is read from the log LIGGGHTS writes with ``-log``:

- thermo: one table per ``run`` command, each after its own header line (``Step Atoms KinEng rke``);
  LIGGGHTS 3.8 prints a compute column ``c_ID`` as ``ID`` in the header.
- timing: the breakdown after every ``Loop time of ...`` line (``Pair time (%) = 1.2 (34.5)``).
- failures: ``ERROR: ...`` (or ``ERROR on proc N: ...``) lines; warnings ``WARNING: ...``.
- dumps: the echoed ``dump ID group custom/vtk N post/name_*.vtk ...`` commands name the VTK files.
"""
from __future__ import annotations

import functools
import math
import os
import re
import shutil
import subprocess
from pathlib import Path

from harness.adapters import register
from harness.adapters.base import EngineAdapter, LogScan, UserError

#: log file name the harness passes with ``-log`` (LIGGGHTS' own default is ``log.liggghts`` too)
LOG_NAME = "log.liggghts"

#: harness timing keys for the section names LIGGGHTS prints in its breakdown (4-letter, "Outpt")
TIMING_SECTIONS = {"Pair": "pair", "Neigh": "neigh", "Comm": "comm", "Outpt": "output",
                   "Modify": "modify", "Other": "other"}

#: thermo header names LIGGGHTS prints for the keywords the harness requires
DEFAULT_COLUMNS = {"step": "Step", "atoms": "Atoms", "ke": "KinEng"}

_LOOP_TIME = re.compile(r"^Loop time of (\S+) on (\d+) procs? for (\d+) steps")
_SECTION_TIME = re.compile(r"^(\w+)\s+time \(%\)\s*=\s*(\S+)")
#: ``Nlocal:    162 ave 252 max 72 min``: particles per rank after a run block (LAMMPS prints the same line)
NLOCAL = re.compile(r"^Nlocal:\s+(\S+) ave (\S+) max (\S+) min")
_EROTATE = re.compile(r"^\s*compute\s+(\S+)\s+\S+\s+erotate/sphere(\s|$)")
_DUMP = re.compile(r"^\s*dump\s+(\S+)\s+\S+\s+(\S+)\s+\d+\s+(\S+)")
#: dump styles that write per-particle VTK (not mesh/vtk, which writes wall meshes)
_PARTICLE_VTK_STYLES = {"custom/vtk", "vtk"}


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def read_log_lines(folder: Path, log_name: str = LOG_NAME) -> list[str]:
    """Lines of the run's LIGGGHTS log; a missing log is a UserError naming the file."""
    path = Path(folder) / log_name
    try:
        return path.read_text(errors="replace").splitlines()
    except FileNotFoundError:
        raise UserError(f"{path}: no LIGGGHTS log (did the run start?)") from None


def parse_thermo_blocks(lines: list[str]) -> list[tuple[list[str], list[list[float]]]]:
    """Thermo tables of a LIGGGHTS log: one ``(header, rows)`` per run block.

    A block starts at a header line (first word ``Step``; the others may be numbers: ``compute 1 all
    erotate/sphere`` is printed as column ``1``) and ends at ``Loop time``, ``ERROR``
    or the next header. Lines in between that are not rows of the header's width (INFO, WARNING, insertion
    reports) are skipped, so interleaved messages do not break a table.
    """
    blocks: list[tuple[list[str], list[list[float]]]] = []
    header: list[str] | None = None
    for line in lines:
        tokens = line.split()
        if not tokens:
            continue
        if tokens[0] == "Step" and len(tokens) > 1:
            header = tokens
            blocks.append((header, []))
            continue
        if header is None:
            continue
        if line.startswith("Loop time") or line.startswith("ERROR"):
            header = None
            continue
        if len(tokens) == len(header) and all(_is_number(t) for t in tokens):
            blocks[-1][1].append([float(t) for t in tokens])
    return blocks


def erotate_compute_ids(lines: list[str]) -> list[str]:
    """IDs of ``compute ID group erotate/sphere`` commands echoed in the log (their column is ``rke``)."""
    return [m.group(1) for line in lines if (m := _EROTATE.match(line))]


def _find_column(columns: list[str], wanted: str) -> str | None:
    """The thermo column a user or script names: exact, then without LIGGGHTS' stripped ``c_``/``v_``/``f_``."""
    if wanted in columns:
        return wanted
    bare = re.sub(r"^[cvf]_", "", wanted)
    for column in columns:
        if re.sub(r"^[cvf]_", "", column) == bare:
            return column
    lowered = {c.lower(): c for c in columns}
    return lowered.get(wanted.lower())


@functools.lru_cache(maxsize=4)
def _mpirun_version(mpirun: str = "mpirun") -> str:
    exe = shutil.which(mpirun)
    if exe is None:
        return ""
    try:
        return subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=20).stdout
    except (OSError, subprocess.TimeoutExpired):
        return ""


def mpi_prefix(mpi: list[str]) -> list[str]:
    """``mpi`` with the Open MPI flags a container needs, added only where needed.

    - ``--allow-run-as-root``: Open MPI refuses to start as root (uid 0, usual in containers and CI).
    - ``--oversubscribe``: Open MPI refuses ``-np`` above the number of cores it detects.
    Flags already present are not repeated; other launchers (MPICH, srun) are left untouched.
    """
    mpi = list(mpi)
    if not mpi or Path(mpi[0]).name not in ("mpirun", "mpiexec", "orterun"):
        return mpi
    if "Open MPI" not in _mpirun_version(mpi[0]):
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


@register
class LiggghtsAdapter(EngineAdapter):
    """LIGGGHTS 3.x: command line, thermo/timing/errors from its log, particle VTK dumps."""

    name = "liggghts"

    def command(self, executable, script, variables, log, mpi=None):
        cmd = mpi_prefix(mpi) if mpi else []
        cmd += list(executable) + ["-in", script]
        for name, value in (variables or {}).items():
            cmd += ["-var", str(name), str(value)]
        return cmd + ["-log", log]

    def log_file(self) -> str:
        return LOG_NAME

    def accepts_script(self, script: str) -> bool:
        """LIGGGHTS reads its own input language under any name (in.*, *.in); a plain ``script`` that is a
        JSON scene of the bundled engine is not for it (name both with ``{"dem": ..., "liggghts": ...}``)."""
        return not script.endswith(".json")

    def read_thermo(self, folder, mapping=None):
        """Thermo of all run blocks as one DataFrame: columns step, atoms, ke (J), rke (J), then the log's own.

        Column mapping (harness name -> log column), first match wins:
        ``mapping`` (``thermo_columns`` of the target or run.config) > Step/Atoms/KinEng > for ``rke`` the
        column of a ``compute ID all erotate/sphere`` echoed in the log. The step repeated at the start of a
        block (``run N`` continues from the previous block's last step) is dropped; the earlier row is kept.
        Blocks with different ``thermo_style`` columns are joined, absent values are NaN.
        """
        import pandas as pd

        lines = read_log_lines(Path(folder), self.log_file())
        log_path = Path(folder) / self.log_file()
        blocks = parse_thermo_blocks(lines)
        frames = []
        last_step = None
        for header, rows in blocks:
            if not rows:
                continue
            if last_step is not None and rows[0][0] == last_step:
                rows = rows[1:]
            if not rows:
                continue
            frames.append(pd.DataFrame(rows, columns=header))
            last_step = frames[-1].iloc[-1, 0]
        if not frames:
            raise UserError(f"{log_path}: no thermo output (a 'thermo' table after 'Step ...' header)")
        table = pd.concat(frames, ignore_index=True)
        columns = list(table.columns)

        wanted = dict(DEFAULT_COLUMNS)
        rke_candidates = erotate_compute_ids(lines) + ["rke", "erotate"]
        chosen: dict[str, str] = {}
        for key in self.required_thermo:
            if mapping and key in mapping:
                column = _find_column(columns, str(mapping[key]))
                if column is None:
                    raise UserError(f"{log_path}: thermo_columns.{key} = {mapping[key]!r} is not a thermo "
                                    f"column (columns: {', '.join(columns)})")
            elif key == "rke":
                column = next((c for c in map(lambda n: _find_column(columns, n), rke_candidates) if c), None)
            else:
                column = _find_column(columns, wanted[key])
            if column is None:
                raise UserError(f"{log_path}: no thermo column for {key!r} (columns: {', '.join(columns)}); "
                                f"name it in thermo_columns of the target or run.config")
            chosen[key] = column

        result = pd.DataFrame({key: table[column] for key, column in chosen.items()})
        for key in ("step", "atoms"):
            if result[key].notna().all():
                result[key] = result[key].astype("int64")
        for column in columns:
            if column not in chosen.values() and column not in result.columns:
                result[column] = table[column]
        return result

    def read_timing(self, folder):
        """Wall time in s summed over every run block: pair, neigh, comm, modify, output, other, total.

        ``total`` is the sum of the ``Loop time of T`` values; the sections are LIGGGHTS' breakdown lines
        (``Pair time (%) = t (percent)``, averaged over processes). Sections LIGGGHTS 3.8 does not print
        (it prints no Modify line; modify time is inside Other) stay 0.
        """
        lines = read_log_lines(Path(folder), self.log_file())
        timing = {key: 0.0 for key in ("pair", "neigh", "comm", "modify", "output", "other", "total")}
        in_breakdown = False
        for line in lines:
            loop = _LOOP_TIME.match(line)
            if loop:
                timing["total"] += float(loop.group(1))
                in_breakdown = True
                continue
            if in_breakdown:
                section = _SECTION_TIME.match(line)
                if section and section.group(1) in TIMING_SECTIONS:
                    value = float(section.group(2))
                    if math.isfinite(value):
                        timing[TIMING_SECTIONS[section.group(1)]] += value
                elif line.startswith("Nlocal") or line.startswith("Setting up run"):
                    in_breakdown = False
        return timing

    def read_breakdown(self, folder, timing=None):
        """The breakdown of every ``Loop time`` block, summed (``harness.breakdown``).

        LIGGGHTS 3.8 prints each section's time averaged over ranks (no min/max; src/finish.cpp), so the load
        imbalance is that of the particles: max/avg of ``Nlocal`` summed over the blocks.
        """
        from harness.breakdown import add_block

        lines = read_log_lines(Path(folder), self.log_file())
        breakdown: dict = {}
        block = None
        particles_avg = particles_max = 0.0
        for line in lines:
            loop = _LOOP_TIME.match(line)
            if loop:
                if block is not None:  # a block without its Nlocal line (a run that stopped there)
                    breakdown = add_block(breakdown, block)
                block = {"sections": {}, "total": float(loop.group(1)), "ranks": int(loop.group(2))}
                continue
            if block is None:
                continue
            section = _SECTION_TIME.match(line)
            if section and section.group(1) in TIMING_SECTIONS:
                value = float(section.group(2))
                if math.isfinite(value):
                    name = {"neigh": "neighbor", "comm": "communication"}.get(TIMING_SECTIONS[section.group(1)],
                                                                            TIMING_SECTIONS[section.group(1)])
                    block["sections"][name] = {"avg": value}
                continue
            nlocal = NLOCAL.match(line)
            if nlocal:
                particles_avg += float(nlocal.group(1))
                particles_max += float(nlocal.group(2))
                breakdown = add_block(breakdown, block)
                block = None
        if block is not None:
            breakdown = add_block(breakdown, block)
        if breakdown:
            breakdown["imbalance"] = particles_max / particles_avg if particles_avg > 0 else None
            breakdown["imbalance_of"] = "particles per rank" if particles_avg > 0 else ""
        return breakdown

    def scan_log(self, folder):
        """``ERROR`` lines (fail the run even with exit code 0) and ``WARNING`` lines, in log order.

        LIGGGHTS writes errors of rank 0 to the log and the screen; errors of other ranks
        (``ERROR on proc N``) only to the screen, so captured ``stdout``/``stderr`` files are scanned too.
        A missing log is reported as an error: LIGGGHTS opens it before reading the script.
        """
        folder = Path(folder)
        scan = LogScan()
        log = folder / self.log_file()
        sources = [log] + sorted(p for p in folder.glob("std*") if p.is_file() and p.suffix in ("", ".txt", ".log"))
        if not log.is_file():
            scan.errors.append(f"{log.name} missing: LIGGGHTS did not start or could not open its log")
        seen_errors: set[str] = set()
        for source in sources:
            if not source.is_file():
                continue
            for line in source.read_text(errors="replace").splitlines():
                text = line.strip()
                if text.startswith("ERROR"):
                    if text not in seen_errors:  # rank 0's errors appear on the screen and in the log
                        seen_errors.add(text)
                        scan.errors.append(text)
                elif text.startswith("WARNING") and source == log:
                    scan.warnings.append(text)
        return scan

    def vtk_files(self, folder):
        """Particle VTK dumps named by the log's ``dump ... custom/vtk N pattern`` commands, by time step.

        ``*`` in a pattern is the time step; files of other patterns sharing the prefix (LIGGGHTS' own
        ``name_boundingBox_*.vtk``) and mesh dumps (``mesh/vtk``) are not particle dumps and are left out.
        """
        folder = Path(folder)
        try:
            lines = read_log_lines(folder, self.log_file())
        except UserError:
            return []
        found: dict[Path, tuple[int, int]] = {}
        patterns: list[str] = []
        for line in lines:
            m = _DUMP.match(line)
            if m and m.group(2) in _PARTICLE_VTK_STYLES and "$" not in m.group(3):
                if m.group(3) not in patterns:
                    patterns.append(m.group(3))
        for order, pattern in enumerate(patterns):
            if "*" not in pattern:
                path = folder / pattern
                if path.is_file():
                    found.setdefault(path, (0, order))
                continue
            directory, name = os.path.split(pattern)
            regex = re.compile("^" + re.escape(name).replace(r"\*", r"(\d+)") + "$")
            base = folder / directory
            if not base.is_dir():
                continue
            for path in base.iterdir():
                m = regex.match(path.name)
                if m:
                    found.setdefault(path, (int(m.group(1)), order))
        return sorted(found, key=lambda p: found[p])

    def default_run_config(self, folder):
        """One serial run per ``in.*`` input script (run name = the part after ``in.``), or None.

        A script that reads a restart file another script of the folder writes depends on that run
        (``read_restart`` / ``write_restart`` file names), so init-then-run tutorials keep their order.
        """
        folder = Path(folder)
        scripts = sorted(p for p in folder.glob("in.*") if p.is_file() and not p.name.endswith("~"))
        if not scripts:
            return None
        writes: dict[str, str] = {}
        reads: dict[str, list[str]] = {}
        for script in scripts:
            text = script.read_text(errors="replace")
            for m in re.finditer(r"^\s*write_restart\s+(\S+)", text, re.M):
                writes[os.path.normpath(m.group(1).replace("*", ""))] = script.name
            reads[script.name] = [os.path.normpath(m.group(1).replace("*", ""))
                                  for m in re.finditer(r"^\s*read_restart\s+(\S+)", text, re.M)]
        runs = []
        for script in scripts:
            run = {"name": script.name[len("in."):] or script.name, "type": "serial", "script": script.name}
            producers = [writes[f] for f in reads[script.name] if f in writes and writes[f] != script.name]
            if producers:
                run["depends_on"] = producers[0][len("in."):]
            runs.append(run)
        return {"runs": runs}
