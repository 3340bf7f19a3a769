"""The store: the Django app (label ``harness``) with its models, migrations and QuerySets, the rules the
CLI and the dashboard share, and the writing of run records into it.

Owns: models (tables), migrations, queries (QuerySet methods: ``current()``, ``failing()``, ``accepted()``,
the overview's tallies), rules (pure predicates, importable by every layer), records (``store_record``),
runrecord (the run.json record), schema (migrating under the store's lock), setup (``setup_store``, opening
the store from outside Django; re-exported here).
May import: ``harness.adapters.base`` (UserError), ``harness.execution`` (make_current when a record's build
becomes current, the workspace) and ``harness.analysis.breakdown``; models are loaded only once Django is set
up (``setup_store``), which is why modules of the other layers import them inside functions.
"""
from harness.store.setup import setup_store  # noqa: F401  (``from harness.store import setup_store``)
