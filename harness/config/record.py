"""The run record, ``run.json`` in a run folder: what one run was and what came out of it. A record read back
(``harness import``) is validated against it; fields a newer harness adds are kept, not refused."""
from __future__ import annotations

from typing import Literal, Union

from pydantic import Field

from harness.config.base import FileModel, OpenModel

#: version of the record layout; 1: before test case hashes; 2: ``testcase_hash`` and strict JSON
RECORD_VERSION = 2
STATES = ("not_executed", "executed", "failed", "post_processed", "consistency_checked", "outdated")
FAILURE_REASONS = ("", "exit_code", "signal", "timeout", "non_finite", "missing_output", "error_line",
                   "interrupted", "post_script", "post_processing", "dependency", "config", "expectation",
                   "stability", "build_failed")
SERIES_KINDS = ("thermo", "plot", "vtk", "textfile")


class SeriesRecord(OpenModel):
    kind: Literal[SERIES_KINDS]
    """what the series was read from"""
    name: str = Field(min_length=1)
    """``thermo``, a declared series, plot or text file"""
    columns: dict[str, list[Union[int, float, str, None]]] = {}
    """equal-length columns; null where a value was not finite"""


class RunRecordFile(OpenModel):
    """One run. Times are ISO 8601 (UTC); ``wall_time`` in s (the engine process, start-up and JIT compilation
    included); ``stepping_time`` in s (the engine's own loop time); ``timing`` in s per category (pair, neigh,
    comm, modify, output, other, total, and what the engine adds); ``breakdown`` the same in the harness'
    sections with min/avg/max over ranks; ``profile`` the folded-stacks file of a profiled run."""

    machine: str
    """machine the run ran on"""
    target: str
    """target name"""
    testcase: str
    """test case path, e.g. ``testcases/settling``"""
    run: str
    """run name"""
    state: Literal[STATES]
    """run state"""
    testcase_hash: str = ""
    """sha256 of the run as it ran (its configuration and files)"""
    target_definition: dict = {}
    """the target file's content"""
    build: dict = {}
    """the build: commit, definition_hash, revision, ..."""
    config: dict = {}
    """the run configuration (a run.config entry)"""
    folder: str = ""
    """the run folder"""
    command: list = []
    """the engine's command line"""
    adapter: str = ""
    """the engine adapter"""
    failure_reason: Literal[FAILURE_REASONS] = ""
    """why a failed run failed"""
    failure_message: str = ""
    """one line saying why"""
    exit_code: int | None = None
    """the engine's exit code"""
    started: str | None = None
    """ISO 8601"""
    finished: str | None = None
    """ISO 8601"""
    wall_time: Union[int, float, None] = None
    """s"""
    stepping_time: Union[int, float, None] = None
    """s"""
    timing: dict = {}
    """s per category"""
    breakdown: dict = {}
    """s per section, min/avg/max over ranks"""
    profile: str = ""
    """folded stacks of a profiled run, relative to its folder"""
    warning_count: int = 0
    """warning lines of the engine"""
    warnings: list = []
    """the first warning lines"""
    series: list[SeriesRecord] = []
    """post-processed series"""
    verdicts: list = []
    """acceptance verdicts"""
    log_tail: str = ""
    """the end of the engine's log"""
    stderr_tail: str = ""
    """the end of its stderr"""
    version: int = RECORD_VERSION
    """record layout version"""
