"""What LIGGGHTS and LAMMPS share (LIGGGHTS is a LAMMPS fork): their log, read by one base class.

Both are run as ``[MPI PREFIX] CODE -in SCRIPT -var NAME VALUE ... -log LOG`` (``EngineAdapter.command``) and
write the same log format:

- thermo: one table per ``run`` command, each after its own header line (``Step Atoms KinEng ...``), read by
  ``parse_thermo_blocks`` and joined by ``LammpsFamilyAdapter.read_thermo``, mapped onto the harness'
  columns by ``EngineAdapter.map_thermo``;
- ``Loop time of T on P procs for N steps`` after each run block (``LOOP_TIME``): the code's own loop time,
  which ``loop_blocks`` reads (the benchmarks read it through here too);
- ``ERROR: ...`` (or ``ERROR on proc N: ...``) and ``WARNING: ...`` lines (``scan_log``);
- one run per ``in.*`` input script of a folder without run.config (``default_run_config``).

The timing breakdown table and the dumps differ between the two: ``harness.adapters.liggghts`` and
``harness.adapters.lammps`` read them.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

import pandas as pd

from harness.adapters.base import EngineAdapter, LogScan, LoopBlock, UserError

#: ``Loop time of 1.23 on 4 procs for 1000 steps with 5000 atoms``: the end of a run block, loop time in s
LOOP_TIME = re.compile(r"^Loop time of (\S+) on (\d+) procs? for (\d+) steps(?: with (\d+) atoms)?")
#: ``Nlocal:    162 ave 252 max 72 min``: particles per rank after a run block
NLOCAL = re.compile(r"^Nlocal:\s+(\S+) ave (\S+) max (\S+) min")
#: an echoed ``dump ID group STYLE N FILE ...`` command
DUMP = re.compile(r"^\s*dump\s+(\S+)\s+\S+\s+(\S+)\s+\d+\s+(\S+)")
_EROTATE = re.compile(r"^\s*compute\s+(\S+)\s+\S+\s+erotate/sphere(\s|$)")


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def read_log_lines(folder: Path, log_name: str, code: str = "LIGGGHTS") -> list[str]:
    """Lines of the run's log; a missing log is a UserError naming the file and the ``code``."""
    path = Path(folder) / log_name
    try:
        return path.read_text(errors="replace").splitlines()
    except FileNotFoundError:
        raise UserError(f"{path}: no {code} log (did the run start?)") from None


def parse_thermo_blocks(lines: list[str]) -> list[tuple[list[str], list[list[float]]]]:
    """Thermo tables of a log: one ``(header, rows)`` per run block.

    A block starts at a header line (first word ``Step``; the others may be numbers: ``compute 1 all
    erotate/sphere`` is printed as column ``1`` by LIGGGHTS) and ends at ``Loop time``, ``ERROR`` or the next
    header. Lines in between that are not rows of the header's width (INFO, WARNING, insertion reports) are
    skipped, so interleaved messages do not break a table.
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


def loop_blocks(lines: list[str]) -> list[LoopBlock]:
    """The run block of every ``Loop time of ...`` line, in log order."""
    return [LoopBlock(seconds=float(m.group(1)), steps=int(m.group(3)), ranks=int(m.group(2)),
                      particles=int(m.group(4)) if m.group(4) else None)
            for line in lines if (m := LOOP_TIME.match(line))]


def dump_patterns(lines: list[str]) -> list[tuple[str, str, str]]:
    """``(dump ID, style, file pattern)`` of the echoed ``dump`` commands, in order; patterns with ``${...}``
    are left out (LAMMPS echoes the substituted line right after)."""
    found = []
    for line in lines:
        m = DUMP.match(line)
        if m and "$" not in m.group(3) and m.groups() not in found:
            found.append(m.groups())
    return found


def dump_files(folder: Path, pattern: str) -> list[tuple[Path, int | None]]:
    """Files of a dump pattern: ``*`` is the time step; no ``*`` is one file (all snapshots in it)."""
    if "*" not in pattern:
        path = folder / pattern
        return [(path, None)] if path.is_file() else []
    directory, name = os.path.split(pattern)
    regex = re.compile("^" + re.escape(name).replace(r"\*", r"(\d+)") + "$")
    base = folder / directory
    if not base.is_dir():
        return []
    return [(p, int(m.group(1))) for p in base.iterdir() if (m := regex.match(p.name))]


class LammpsFamilyAdapter(EngineAdapter):
    """The log of a LAMMPS-family code: thermo blocks, loop times, error lines, ``in.*`` test cases.

    Subclasses set ``name``, ``code`` (as messages name it), ``log_name`` and ``default_thermo_columns``, and
    read their own timing table and dumps.
    """

    code = "LAMMPS"
    log_name = "log.lammps"
    #: join thermo blocks on the columns every block prints (True), or on all of them, absent values NaN
    common_thermo_columns = False

    def log_file(self) -> str:
        return self.log_name

    def log_lines(self, folder) -> list[str]:
        """Lines of the run's log (a UserError naming the file when there is none)."""
        return read_log_lines(Path(folder), self.log_file(), self.code)

    def log_lines_if_any(self, folder) -> list[str]:
        """Lines of the run's log, [] without one (a run that did not start has no timing and no dumps)."""
        try:
            return self.log_lines(folder)
        except UserError:
            return []

    def rke_candidates(self, lines: list[str]) -> list[str]:
        """Column names that may hold the rotational kinetic energy, best first (``map_thermo``'s candidates)."""
        return erotate_compute_ids(lines)

    def read_thermo(self, folder, mapping=None):
        """Thermo of all run blocks as one DataFrame: step, atoms, ke, rke, then the log's own columns.

        Column mapping (harness name -> log column, ``map_thermo``), first match wins: ``mapping``
        (``thermo_columns`` of the target or run.config) > ``default_thermo_columns`` > for ``rke`` the column
        of a ``compute ID all erotate/sphere`` echoed in the log (``rke_candidates``). The step repeated at
        the start of a block (``run N`` continues from the previous block's last step) is dropped; the
        earlier row is kept. Blocks with other columns are joined (``common_thermo_columns``).
        """
        lines = self.log_lines(folder)
        source = str(Path(folder) / self.log_file())
        frames, last_step = [], None
        for header, rows in parse_thermo_blocks(lines):
            if rows and last_step is not None and rows[0][0] == last_step:
                rows = rows[1:]
            if not rows:
                continue
            frames.append(pd.DataFrame(rows, columns=header))
            last_step = rows[-1][0]
        if not frames:
            raise UserError(f"{source}: no thermo output (a 'thermo' table after a 'Step ...' header)")
        if self.common_thermo_columns:
            # a column only some blocks print (e.g. CPU added by a later thermo_style) would be NaN in the others
            common = [c for c in frames[0].columns if all(c in f.columns for f in frames)]
            frames = [f[common] for f in frames]
        table = pd.concat(frames, ignore_index=True)
        return self.map_thermo(table, mapping, source, {"rke": self.rke_candidates(lines)})

    def loop_blocks(self, folder) -> list[LoopBlock]:
        """Each run block's ``Loop time of T on P procs for N steps with A atoms`` ([] without a log)."""
        return loop_blocks(self.log_lines_if_any(folder))

    def scan_log(self, folder) -> LogScan:
        """``ERROR`` lines (they fail a run even with exit code 0) and the log's ``WARNING`` lines, in order.

        Errors of rank 0 go to the log and the screen; errors of other ranks (``ERROR on proc N``) only to the
        screen, so captured ``stdout``/``stderr`` files are scanned too, each error kept once. A missing log
        is an error: the code opens it before reading the script.
        """
        folder = Path(folder)
        scan = LogScan()
        log = folder / self.log_file()
        if not log.is_file():
            scan.errors.append(f"{log.name} missing: {self.code} did not start or could not open its log")
        sources = [log] + sorted(p for p in folder.glob("std*") if p.is_file() and p.suffix in ("", ".txt", ".log"))
        for source in sources:
            if not source.is_file():
                continue
            for line in source.read_text(errors="replace").splitlines():
                text = line.strip()
                if text.startswith("ERROR"):
                    if text not in scan.errors:
                        scan.errors.append(text)
                elif text.startswith("WARNING") and source == log:
                    scan.warnings.append(text)
        return scan

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
