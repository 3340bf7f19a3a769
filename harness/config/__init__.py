"""The declarative schema of the harness' files: targets (``targets/*.json``), run.config, generic adapter
definition files and run records (``run.json``).

Each file kind is a pydantic model (``runconfig.RunConfig``, ``target.Target``, ``adapter.AdapterFile``,
``record.RunRecord``): its fields, their types, bounds, choices, defaults and descriptions are written once
there (pydantic 2 gives strict types, JSON Schema export and typed objects from that one declaration). From the
models come

- the JSON Schema of each kind (``export.json_schema``, printed by ``harness schema KIND``), so that an editor
  validates a file while it is typed, and a test validates every file of the repository against it;
- docs/run-config.md (``export.markdown``, printed by ``harness schema run.config --markdown``);
- the validation of each file (``check.validate``: each problem a ``harness.jsonfile.Problem``, worded by the
  field's ``Says``), and the typed object of a valid one.

The readers (``harness.targets``, ``harness.testcases``, ``harness.adapters.generic``, ``harness.runrecord``)
add what a schema cannot say (a file that must exist, a dependency cycle, a field only one recipe takes) and
report every problem as a ``harness.jsonfile.Problem``: the file, the JSON path and the message.

The constant tables the schema states (run types, reductions, run states, failure reasons, recipes) live here
too and are imported from here. This package imports pydantic and ``harness.jsonfile`` (``Problem``; it
brings ``UserError`` of ``harness.adapters.base``) only; never the store, the runner or an adapter.
"""
from __future__ import annotations

from harness.config.base import known_fields

__all__ = ["known_fields"]
