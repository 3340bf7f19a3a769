"""The run record, ``run.json`` in a run folder: what one run was and what came out of it. A record read back
(``harness import``) is validated against it; fields a newer harness adds are kept, not refused."""
from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import ConfigDict, Field

from harness.config.base import OpenModel
from harness.config.check import Says

#: version of the record layout; 1: before test case hashes; 2: ``testcase_hash`` and strict JSON
RECORD_VERSION = 2
#: run states and what the store (harness.store.models.Run.State) and the pages call them
STATE_LABELS = {"not_executed": "not executed", "executed": "executed", "failed": "failed",
                "post_processed": "post-processed", "consistency_checked": "version-consistency-checked",
                "outdated": "outdated"}
STATES = tuple(STATE_LABELS)
#: why a failed run failed ("": it did not), with the store's labels (harness.store.models.Run.FailureReason)
FAILURE_LABELS = {"": "none", "exit_code": "non-zero exit code", "signal": "killed by a signal",
                  "timeout": "timeout", "non_finite": "non-finite values", "missing_output": "missing output",
                  "error_line": "error line in the log", "interrupted": "interrupted",
                  "post_script": "post script failed", "post_processing": "post-processing failed",
                  "dependency": "dependency failed", "config": "invalid configuration",
                  "expectation": "expectation not met", "stability": "stability check failed",
                  "build_failed": "build failed"}
FAILURE_REASONS = tuple(FAILURE_LABELS)
SERIES_KINDS = ("thermo", "plot", "vtk", "textfile")


#: the JSON Schema of one series (``harness.execution.postprocess.frame_to_series``); the record holds series as plain
#: objects, their rules are checked by ``harness.store.runrecord.validate``
SERIES_SCHEMA = {"type": "object", "required": ["kind", "name"], "properties": {
    "kind": {"enum": list(SERIES_KINDS)}, "name": {"type": "string", "minLength": 1},
    "x_column": {"type": "string"}, "columns": {"type": "object", "additionalProperties": {
        "type": "array", "items": {"type": ["number", "string", "null"]}}}}}


class RunRecord(OpenModel):
    """One run. Times are ISO 8601 (UTC); ``wall_time`` in s (the engine process, start-up and JIT compilation
    included); ``stepping_time`` in s (the engine's own loop time); ``timing`` in s per category (pair, neigh,
    comm, modify, output, other, total, and what the engine adds); ``breakdown`` the same in the harness'
    sections with min/avg/max over ranks; ``profile`` the folded-stacks file of a profiled run.

    ``harness.execution.execute`` fills one while it runs a run (``fail`` when it fails), ``harness.store.records`` stores it;
    a record read back is validated against this model (fields a newer harness adds are kept)."""

    model_config = ConfigDict(frozen=False)

    machine: str
    """machine the run ran on"""
    target: str
    """target name"""
    testcase: str
    """test case path, e.g. ``testcases/settling``"""
    run: str
    """run name"""
    state: Annotated[Literal[STATES], Says(bound="unknown state {value!r} (known: {known})")] = "not_executed"
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
    failure_reason: Annotated[Literal[FAILURE_REASONS], Says(bound="unknown reason {value!r}")] = ""
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
    series: list[dict] = Field([], json_schema_extra={"items": SERIES_SCHEMA})
    """post-processed series"""
    verdicts: list = []
    """acceptance verdicts"""
    log_tail: str = ""
    """the end of the engine's log"""
    stderr_tail: str = ""
    """the end of its stderr"""
    version: int = RECORD_VERSION
    """record layout version"""

    def fail(self, reason: str, message: str) -> "RunRecord":
        """This record, failed for ``reason`` (one of ``FAILURE_REASONS``) with a one-line ``message``."""
        self.state, self.failure_reason, self.failure_message = "failed", reason, message
        return self

    @property
    def failed(self) -> bool:
        return self.state == "failed"

    def to_dict(self) -> dict:
        """The record as ``run.json`` holds it (fields in declaration order, then those of a newer harness)."""
        return self.model_dump(by_alias=True)
