"""Adapter for LAMMPS with the GRANULAR package (Debian package ``lammps``: ``/usr/bin/lmp``).

LAMMPS is run as a program from the run folder, like LIGGGHTS (a LAMMPS fork) and the bundled engine::

    [mpirun [--allow-run-as-root] [--oversubscribe] -np N] lmp -in in.scene -var NAME VALUE ... -log log.lammps

Everything the harness needs is read from the log LAMMPS writes with ``-log`` (the format of LAMMPS
29 Sep 2021, the Debian release, and of later ones):

- thermo: one table per ``run``, each after its own header (``Step Atoms KinEng c_rke``), joined on the columns
  every block prints; compute columns keep their ``c_`` prefix (LIGGGHTS strips it). Only the one-line thermo
  style is read (not ``multi``/``yaml``). ``ke`` is LAMMPS' ``KinEng``, 1/2 dof kB T: with one atom in 3d the
  default dof 3N - 3 is 0 and so is ``KinEng`` (``compute_modify thermo_temp extra/dof 0`` keeps it 1/2 m v^2).
- timing: ``Loop time of T on P procs for N steps with A atoms`` and the table after
  ``MPI task timing breakdown:`` (``Pair | min | avg | max | %varavg | %total``); the harness takes the
  ``avg`` column of Pair, Neigh, Comm, Output, Modify, Other, summed over run blocks.
- failures: ``ERROR: ...`` (rank 0, log and screen) and ``ERROR on proc N: ...`` (screen only) lines;
  ``WARNING: ...`` lines of the log are counted.
- dumps: the echoed ``dump ID group custom N file ...`` commands. The Debian build has no VTK package, so
  text dumps (``custom``, ``custom/gz``) are converted to VTK PolyData (``vtk/<file>_<step>.vtp``, one file per
  snapshot, a point per atom, every column a point array, ``v``/``f``/``omega`` vectors) and read like any
  other dump; ``dump vtk`` files of a build with the VTK package are read as they are.

The thermo energy columns are taken as printed: LAMMPS normalises extensive thermo values by the atom count
when ``thermo_modify norm yes``, the default of ``units lj`` (``norm no`` for ``si``, LAMMPS docs,
thermo_modify). The cross-code scenes use ``units si`` and ``thermo_modify norm no``.
"""
from __future__ import annotations

import gzip
import math
import re
import shutil
from pathlib import Path

from harness.adapters import register
from harness.adapters.base import UserError
from harness.adapters.lammps_family import (
    LOOP_TIME,
    LammpsFamilyAdapter,
    dump_files,
    dump_patterns,
    erotate_compute_ids,
)
from harness.analysis.breakdown import add_block, imbalance_of_sections

#: log file name the harness passes with ``-log`` (LAMMPS' own default is ``log.lammps`` too)
LOG_NAME = "log.lammps"
#: harness timing keys for the section names of LAMMPS' "MPI task timing breakdown" table
TIMING_SECTIONS = {"Pair": "pair", "Neigh": "neigh", "Comm": "comm", "Output": "output", "Modify": "modify",
                   "Other": "other", "Bond": "bond", "Kspace": "kspace"}
TIMING_KEYS = ("pair", "neigh", "comm", "modify", "output", "other", "total")

_TABLE_ROW = re.compile(r"^(\w+)\s*\|")
#: text dump styles converted to VTK, and styles LAMMPS writes as VTK itself (VTK package)
_TEXT_DUMPS = {"custom", "custom/gz"}
_VTK_DUMPS = {"vtk", "custom/vtk"}
#: per-atom vectors assembled from dump columns (name in the .vtp -> dump columns)
_VECTORS = {"v": ("vx", "vy", "vz"), "f": ("fx", "fy", "fz"), "omega": ("omegax", "omegay", "omegaz")}
#: dump columns that may hold the position, preferred first (unwrapped, wrapped)
_POSITIONS = (("xu", "yu", "zu"), ("x", "y", "z"))


def parse_timing(lines: list[str]) -> dict[str, float]:
    """Wall time in s summed over run blocks: ``total`` from ``Loop time of T``, sections from the avg column.

    LAMMPS prints, after each run (src/finish.cpp)::

        Section |  min time  |  avg time  |  max time  |%varavg| %total
        Pair    | 0.0002386  | 0.0002386  | 0.0002386  |   0.0 | 25.04
        Other   |            | 7.145e-05  |            |       |  7.50
    """
    timing = {key: 0.0 for key in TIMING_KEYS}
    in_table = False
    for line in lines:
        loop = LOOP_TIME.match(line)
        if loop:
            timing["total"] += float(loop.group(1))
            continue
        if line.startswith("Section |"):
            in_table = True
            continue
        if not in_table:
            continue
        row = _TABLE_ROW.match(line)
        if row is None:
            if line.strip() and not line.startswith("---"):
                in_table = False
            continue
        cells = [cell.strip() for cell in line.split("|")]
        if row.group(1) in TIMING_SECTIONS and len(cells) >= 3:
            try:
                value = float(cells[2])
            except ValueError:
                continue
            if math.isfinite(value):
                key = TIMING_SECTIONS[row.group(1)]
                timing[key] = timing.get(key, 0.0) + value
    return timing


#: LAMMPS' table rows onto the harness' sections (harness.analysis.breakdown); Bond and Kspace count as pair work
BREAKDOWN_SECTIONS = {"Pair": "pair", "Bond": "pair", "Kspace": "pair", "Neigh": "neighbor",
                      "Comm": "communication", "Output": "output", "Modify": "modify", "Other": "other"}


def parse_breakdown(lines: list[str]) -> dict:
    """Sections with min/avg/max over ranks from every "MPI task timing breakdown" table, summed over blocks;
    load imbalance max/avg of the pair time (``harness.analysis.breakdown``)."""

    breakdown: dict = {}
    block = None
    in_table = False
    for line in lines:
        loop = LOOP_TIME.match(line)
        if loop:
            if block is not None:
                breakdown = add_block(breakdown, block)
            block = {"sections": {}, "total": float(loop.group(1)), "ranks": int(loop.group(2))}
            in_table = False
            continue
        if block is None:
            continue
        if line.startswith("Section |"):
            in_table = True
            continue
        row = _TABLE_ROW.match(line) if in_table else None
        if row is None:
            if in_table and line.strip() and not line.startswith("---"):
                in_table = False
                breakdown = add_block(breakdown, block)
                block = None
            continue
        cells = [cell.strip() for cell in line.split("|")]
        section = BREAKDOWN_SECTIONS.get(row.group(1))
        if section is None or len(cells) < 4:
            continue
        values = {}
        for stat, cell in zip(("min", "avg", "max"), cells[1:4]):
            try:
                number = float(cell)
            except ValueError:
                continue
            if math.isfinite(number):
                values[stat] = number
        into = block["sections"].setdefault(section, {})
        for stat, number in values.items():
            into[stat] = into.get(stat, 0.0) + number
    if block is not None:
        breakdown = add_block(breakdown, block)
    if breakdown:
        breakdown["imbalance"] = imbalance_of_sections(breakdown, "pair")
        breakdown["imbalance_of"] = "pair time" if breakdown["imbalance"] is not None else ""
    return breakdown


def _open_text(path: Path):
    if path.suffix == ".gz":
        return gzip.open(path, "rt", errors="replace")
    return open(path, errors="replace")


def read_custom_dump(path: Path) -> list[tuple[int, list[str], list[list[float]]]]:
    """Snapshots of a LAMMPS text dump (``dump custom``): ``(step, columns, rows)`` per ``ITEM: TIMESTEP``.

    A truncated last snapshot (the run was killed while writing) is dropped; a malformed file is a
    UserError naming it.
    """
    snapshots = []
    with _open_text(path) as handle:
        lines = handle.read().splitlines()
    i = 0
    while i < len(lines):
        if not lines[i].startswith("ITEM: TIMESTEP"):
            i += 1
            continue
        try:
            step = int(lines[i + 1].split()[0])
            if not lines[i + 2].startswith("ITEM: NUMBER OF ATOMS"):
                raise ValueError("ITEM: NUMBER OF ATOMS expected")
            count = int(lines[i + 3].split()[0])
            j = i + 4
            while j < len(lines) and not lines[j].startswith("ITEM: ATOMS"):
                j += 1
            columns = lines[j].split()[2:]
        except (IndexError, ValueError) as exc:
            raise UserError(f"{path}: line {i + 1}: not a LAMMPS custom dump snapshot ({exc})") from None
        rows = []
        for line in lines[j + 1:j + 1 + count]:
            words = line.split()
            if len(words) != len(columns):
                break
            rows.append([float(w) for w in words])
        if len(rows) < count:
            break  # truncated snapshot
        snapshots.append((step, columns, rows))
        i = j + 1 + count
    return snapshots


def write_vtp(path: Path, columns: list[str], rows: list[list[float]]) -> None:
    """One snapshot as VTK XML PolyData: a vertex per atom, each column a point array, vectors assembled."""
    # a heavy library, loaded when this runs, not at every `harness` start
    import numpy as np
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk

    data = np.array(rows, dtype=float).reshape(len(rows), len(columns))
    index = {name: k for k, name in enumerate(columns)}
    position = next((names for names in _POSITIONS if all(n in index for n in names)), None)
    if position is None:
        raise UserError(f"{path.name}: the dump has no x y z (or xu yu zu) columns (columns: {' '.join(columns)})")
    points = vtk.vtkPoints()
    points.SetData(numpy_to_vtk(np.ascontiguousarray(data[:, [index[n] for n in position]]), deep=True))
    poly = vtk.vtkPolyData()
    poly.SetPoints(points)
    cells = vtk.vtkCellArray()
    for k in range(len(rows)):
        cells.InsertNextCell(1)
        cells.InsertCellPoint(k)
    poly.SetVerts(cells)
    point_data = poly.GetPointData()
    arrays = {name: data[:, k] for name, k in index.items() if name not in position}
    for vector, names in _VECTORS.items():
        if all(n in index for n in names):
            arrays[vector] = data[:, [index[n] for n in names]]
    for name, values in arrays.items():
        array = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
        array.SetName(name)
        point_data.AddArray(array)
    writer = vtk.vtkXMLPolyDataWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(poly)
    writer.SetDataModeToBinary()
    if not writer.Write():
        raise UserError(f"{path}: VTK writer failed")


@register
class LammpsAdapter(LammpsFamilyAdapter):
    """LAMMPS (GRANULAR package): command line, thermo/timing/errors from its log, custom dumps as VTK.

    The command line, the thermo blocks, the error lines and the ``in.*`` default run.config are those of
    every LAMMPS-family code (``harness.adapters.lammps_family``); the timing table, the thermo column names
    and the dumps are LAMMPS' own.
    """

    name = "lammps"
    code = "LAMMPS"
    log_name = LOG_NAME
    default_thermo_columns = {"step": "Step", "atoms": "Atoms", "ke": "KinEng"}
    #: a column only some blocks print (e.g. CPU added by a later thermo_style) is left out
    common_thermo_columns = True
    #: folder of the run where converted dumps are written
    vtk_folder = "vtk"

    def accepts_script(self, script: str) -> bool:
        """LAMMPS input under any name (``in.*``, ``*.in``, ``*.lmp``), but not a JSON scene of the bundled
        engine or a YADE Python script."""
        return not script.endswith((".json", ".py"))

    def rke_candidates(self, lines: list[str]) -> list[str]:
        """The column ``c_ID`` of a ``compute ID group erotate/sphere`` echoed in the log (LAMMPS keeps the
        ``c_`` prefix)."""
        return [f"c_{cid}" for cid in erotate_compute_ids(lines)]

    def read_timing(self, folder):
        """Seconds summed over run blocks: total (``Loop time``), pair, neigh, comm, modify, output, other."""
        return parse_timing(self.log_lines_if_any(folder))

    def read_breakdown(self, folder, timing=None):
        """Sections with min/avg/max over ranks (``parse_breakdown``); {} without a log."""
        return parse_breakdown(self.log_lines_if_any(folder))

    def vtk_files(self, folder):
        """Per-atom VTK files of the run's dumps, by time step (converted from text dumps on first call)."""

        folder = Path(folder)
        lines = self.log_lines_if_any(folder)
        found: dict[Path, tuple[int, int]] = {}
        target = folder / self.vtk_folder
        converted = False
        for order, (dump_id, style, pattern) in enumerate(dump_patterns(lines)):
            if style in _VTK_DUMPS:
                for path, step in dump_files(folder, pattern):
                    found.setdefault(path, (step or 0, order))
                continue
            if style not in _TEXT_DUMPS:
                continue
            if not converted:
                if target.is_dir():
                    shutil.rmtree(target)
                target.mkdir()
                converted = True
            for path, _step in sorted(dump_files(folder, pattern)):
                for step, columns, rows in read_custom_dump(path):
                    out = target / f"{dump_id}_{step}.vtp"
                    if out in found:
                        continue
                    write_vtp(out, columns, rows)
                    found[out] = (step, order)
        return sorted(found, key=lambda p: found[p])
