"""A generic adapter definition file: a DEM code without an adapter of its own, described in JSON (``"engine":
"generic:FILE"`` in a target). ``harness.adapters.generic`` reads it."""
from __future__ import annotations

from typing import Literal

from pydantic import Field

from harness.config.base import FileModel

TIMING_KEYS = ("pair", "neigh", "comm", "modify", "output", "other", "total")


class Thermo(FileModel):
    """Where the thermo output is: ``csv`` (a file in the run folder) or ``log_pattern`` (a regular expression
    with named groups, one row per matching line of the log, or of ``file``); exactly one of them."""

    csv: str | None = None
    """a CSV file of the run folder"""
    delimiter: str = ","
    """``,`` by default; ``whitespace`` for columns separated by blanks"""
    log_pattern: str | None = None
    """a regular expression with named groups, e.g. ``(?P<step>\\d+)``"""
    file: str | None = None
    """the file ``log_pattern`` reads (default: the log)"""
    columns: dict[str, str] = {}
    """the code's names for step, atoms, ke, rke (unmapped ones must be printed under those names)"""


class AdapterFile(FileModel):
    """How to start a code and where its results land."""

    description: str | None = None
    """free text"""
    command: list[str] = Field(json_schema_extra={"contains": {"pattern": r"\{script\}"}})
    """the command line; ``{executable}`` is the target's executable (all its words), ``{script}`` the run's
    script, ``{log}`` the log file, ``{variables}`` one copy of ``variable`` per run.config variable"""
    variable: list[str] = ["-var", "{name}", "{value}"]
    """how one variable is passed"""
    log: str = "log.txt"
    """the log file"""
    scripts: list[str] = []
    """glob patterns of the scripts a plain run.config ``script`` may name for this code (default: any)"""
    thermo: Thermo
    """where the thermo output is"""
    timing: dict[Literal[TIMING_KEYS], str] = {}
    """per timing key a regular expression whose first group is seconds, summed over the log's matching
    lines"""
    errors: list[str] = ["^ERROR"]
    """regular expressions of error lines in the log, stdout and stderr"""
    warnings: list[str] = ["^WARNING"]
    """regular expressions of warning lines"""
    vtk: list[str] = []
    """glob patterns of the particle dumps (VTK files), in step order"""
