"""The files people write: targets (``targets/NAME.json``), test cases (``run.config``) and what they declare
(sweeps, acceptance checks), read and validated from a git revision or the working tree, and the declarative
schema of those files and of run records (``run.json``).

Owns: targets, testcases, sweep, acceptance, revisions (``TARGET@REV``, ``A..B``), scaffold (``harness new``),
jsonfile (reading JSON input with problems that name file and field), gitrepo (git operations), and the schema:
each file kind is a pydantic model (``runconfig.RunConfig``, ``target.Target``, ``adapter.AdapterFile``,
``record.RunRecord``) whose fields, types, bounds, choices, defaults and descriptions are written once (pydantic 2
gives strict types, JSON Schema export and typed objects from that one declaration). From the models come

- the JSON Schema of each kind (``export.json_schema``, printed by ``harness schema KIND``), so that an editor
  validates a file while it is typed, and a test validates every file of the repository against it;
- docs/run-config.md (``export.markdown``, printed by ``harness schema run.config --markdown``);
- the validation of each file (``check.validate``: each problem a ``harness.config.jsonfile.Problem``, worded by
  the field's ``Says``), and the typed object of a valid one.

The readers (``targets``, ``testcases``, ``harness.adapters.generic``, ``harness.store.runrecord``) add what a
schema cannot say (a file that must exist, a dependency cycle, a field only one recipe takes). The constant
tables the schema states (run types, reductions, run states, failure reasons, recipes) live here too.

May import: pydantic, ``harness.adapters`` (the code a target runs: its test case conventions) and
``harness.execution.workspace`` (where mirrors and exports live); never the store or the layers above.
"""
from __future__ import annotations

from harness.config.base import known_fields

__all__ = ["known_fields"]
