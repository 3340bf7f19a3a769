"""Adapter for LIGGGHTS (CFDEMproject/LIGGGHTS-PUBLIC 3.x, Debian package ``liggghts``).

LIGGGHTS is run as a program from the run folder (its scripts name ``post/`` and ``meshes/`` relative to the
working directory)::

    [mpirun [--allow-run-as-root] [--oversubscribe] -np N] liggghts -in in.scene -var NAME VALUE ... -log log.liggghts

Everything the harness needs is read from the log LIGGGHTS writes with ``-log``; what LAMMPS reads the same
way (thermo blocks, loop times, error lines, ``in.*`` test cases) is ``harness.adapters.lammps_family``:

- thermo: one table per ``run`` command, each after its own header line (``Step Atoms KinEng rke``);
  LIGGGHTS 3.8 prints a compute column ``c_ID`` as ``ID`` in the header.
- timing: the breakdown after every ``Loop time of ...`` line (``Pair time (%) = 1.2 (34.5)``).
- failures: ``ERROR: ...`` (or ``ERROR on proc N: ...``) lines; warnings ``WARNING: ...``.
- dumps: the echoed ``dump ID group custom/vtk N post/name_*.vtk ...`` commands name the VTK files.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

from harness.adapters import register
from harness.adapters.lammps_family import (
    LOOP_TIME,
    NLOCAL,
    LammpsFamilyAdapter,
    dump_files,
    dump_patterns,
    erotate_compute_ids,
)
from harness.analysis.breakdown import add_block

#: log file name the harness passes with ``-log`` (LIGGGHTS' own default is ``log.liggghts`` too)
LOG_NAME = "log.liggghts"

#: harness timing keys for the section names LIGGGHTS prints in its breakdown (4-letter, "Outpt")
TIMING_SECTIONS = {"Pair": "pair", "Neigh": "neigh", "Comm": "comm", "Outpt": "output",
                   "Modify": "modify", "Other": "other"}

#: thermo header names LIGGGHTS prints for the keywords the harness requires
DEFAULT_COLUMNS = {"step": "Step", "atoms": "Atoms", "ke": "KinEng"}

_SECTION_TIME = re.compile(r"^(\w+)\s+time \(%\)\s*=\s*(\S+)")
#: dump styles that write per-particle VTK (not mesh/vtk, which writes wall meshes)
_PARTICLE_VTK_STYLES = {"custom/vtk", "vtk"}


@register
class LiggghtsAdapter(LammpsFamilyAdapter):
    """LIGGGHTS 3.x: command line, thermo/timing/errors from its log, particle VTK dumps."""

    name = "liggghts"
    code = "LIGGGHTS"
    log_name = LOG_NAME
    default_thermo_columns = DEFAULT_COLUMNS

    def accepts_script(self, script: str) -> bool:
        """LIGGGHTS reads its own input language under any name (in.*, *.in); a plain ``script`` that is a
        JSON scene of the bundled engine is not for it (name both with ``{"dem": ..., "liggghts": ...}``)."""
        return not script.endswith(".json")

    def rke_candidates(self, lines: list[str]) -> list[str]:
        """The column of a ``compute ID all erotate/sphere`` echoed in the log (LIGGGHTS 3.8 prints ``c_ID``
        as ``ID``), then ``rke`` and ``erotate``."""
        return erotate_compute_ids(lines) + ["rke", "erotate"]

    def read_timing(self, folder):
        """Wall time in s summed over every run block: pair, neigh, comm, modify, output, other, total.

        ``total`` is the sum of the ``Loop time of T`` values; the sections are LIGGGHTS' breakdown lines
        (``Pair time (%) = t (percent)``, averaged over processes). Sections LIGGGHTS 3.8 does not print
        (it prints no Modify line; modify time is inside Other) stay 0.
        """
        lines = self.log_lines(folder)
        timing = {key: 0.0 for key in ("pair", "neigh", "comm", "modify", "output", "other", "total")}
        in_breakdown = False
        for line in lines:
            loop = LOOP_TIME.match(line)
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
        """The breakdown of every ``Loop time`` block, summed (``harness.analysis.breakdown``).

        LIGGGHTS 3.8 prints each section's time averaged over ranks (no min/max; src/finish.cpp), so the load
        imbalance is that of the particles: max/avg of ``Nlocal`` summed over the blocks.
        """

        lines = self.log_lines(folder)
        breakdown: dict = {}
        block = None
        particles_avg = particles_max = 0.0
        for line in lines:
            loop = LOOP_TIME.match(line)
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

    def vtk_files(self, folder):
        """Particle VTK dumps named by the log's ``dump ... custom/vtk N pattern`` commands, by time step.

        ``*`` in a pattern is the time step; files of other patterns sharing the prefix (LIGGGHTS' own
        ``name_boundingBox_*.vtk``) and mesh dumps (``mesh/vtk``) are not particle dumps and are left out.
        """
        folder = Path(folder)
        lines = self.log_lines_if_any(folder)
        found: dict[Path, tuple[int, int]] = {}
        patterns: list[str] = []
        for _dump_id, style, pattern in dump_patterns(lines):
            if style in _PARTICLE_VTK_STYLES and pattern not in patterns:
                patterns.append(pattern)
        for order, pattern in enumerate(patterns):
            for path, step in dump_files(folder, pattern):
                found.setdefault(path, (step or 0, order))
        return sorted(found, key=lambda p: found[p])
