"""A generic adapter definition file: a DEM code without an adapter of its own, described in JSON (``"engine":
"generic:FILE"`` in a target). ``harness.adapters.generic`` reads it."""
from __future__ import annotations

from typing import Annotated, ClassVar

from pydantic import Field

from harness.config.base import FileModel
from harness.config.check import Says

TIMING_KEYS = ("pair", "neigh", "comm", "modify", "output", "other", "total")
Regex = Annotated[str, Says(what="a regular expression (string)")]
Regexes = Annotated[list[Regex], Says(what="a list of regular expressions", item="a string")]
Globs = Annotated[list[str], Says(what="a list of glob patterns", item="a string")]


class Thermo(FileModel):
    """Where the thermo output is: ``csv`` (a file in the run folder) or ``log_pattern`` (a regular expression
    with named groups, one row per matching line of the log, or of ``file``); exactly one of them."""

    csv: str | None = None
    """a CSV file of the run folder"""
    delimiter: str = ","
    """``,`` by default; ``whitespace`` for columns separated by blanks"""
    log_pattern: Regex | None = None
    """a regular expression with named groups, e.g. ``(?P<step>\\d+)``"""
    file: str | None = None
    """the file ``log_pattern`` reads (default: the log)"""
    columns: Annotated[dict[str, str], Says(what="an object: harness name -> the code's column",
                                            item="a column name")] = {}
    """the code's names for step, atoms, ke, rke (unmapped ones must be printed under those names)"""


class Timing(FileModel):
    """Per timing key a regular expression whose first group is seconds, summed over the log's matching lines."""

    says: ClassVar[Says] = Says(unknown="unknown timing key (known: {known})")
    pair: Regex | None = None
    """pair forces"""
    neigh: Regex | None = None
    """neighbour lists"""
    comm: Regex | None = None
    """communication"""
    modify: Regex | None = None
    """fixes"""
    output: Regex | None = None
    """output"""
    other: Regex | None = None
    """the rest"""
    total: Regex | None = None
    """the whole loop (the stepping time)"""


class AdapterFile(FileModel):
    """How to start a code and where its results land."""

    description: str | None = None
    """free text"""
    command: Annotated[list[str], Says(what="a list of strings", item="a string",
                                       missing='required: the command line, e.g. ["{executable}", "{script}"]')] \
        = Field(json_schema_extra={"contains": {"pattern": r"\{script\}"}})
    """the command line; ``{executable}`` is the target's executable (all its words), ``{script}`` the run's
    script, ``{log}`` the log file, ``{variables}`` one copy of ``variable`` per run.config variable"""
    variable: Annotated[list[str], Says(what="a list of strings", item="a string")] = ["-var", "{name}", "{value}"]
    """how one variable is passed"""
    log: str = "log.txt"
    """the log file"""
    scripts: Globs = []
    """glob patterns of the scripts a plain run.config ``script`` may name for this code (default: any)"""
    thermo: Annotated[Thermo, Says(what="an object",
                                   missing='required: {"csv": FILE} or {"log_pattern": REGEX}, with columns')]
    """where the thermo output is"""
    timing: Annotated[Timing, Says(what="an object: timing key -> regular expression")] = Timing()
    """per timing key a regular expression whose first group is seconds, summed over the log's matching
    lines"""
    errors: Regexes = ["^ERROR"]
    """regular expressions of error lines in the log, stdout and stderr"""
    warnings: Regexes = ["^WARNING"]
    """regular expressions of warning lines"""
    vtk: Globs = []
    """glob patterns of the particle dumps (VTK files), in step order"""
