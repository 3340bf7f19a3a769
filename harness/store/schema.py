"""Bringing the store's schema up to date when a program opens it (the dashboard's servers, createsuperuser).

Every program that opens the store - the CLI (``harness.store.setup_store``), the dashboard's servers,
``createsuperuser`` - brings its schema up to date here, so that two of them starting at once never both
migrate it: an SQLite store (one file on this machine) under the workspace lock ``migrate``; a PostgreSQL
store, possibly shared by several machines where a file lock protects nothing, under a PostgreSQL advisory
lock held on the server.
"""
from __future__ import annotations

from filelock import Timeout

from harness.execution.workspace import workspace

#: name of the workspace lock held while migrating (harness.execution.workspace.Workspace.lock)
LOCK_NAME = "migrate"
#: seconds to wait for another process that is migrating the same store
LOCK_TIMEOUT = 600
#: key of the PostgreSQL advisory lock held while migrating (a constant only the harness uses)
ADVISORY_LOCK = 0x64656D68


class SchemaBehind(Exception):
    """The store's schema is older than this code and is not migrated here; the message names the command."""


def pending_migrations(using: str = "default") -> list[str]:
    """``app.migration`` names this code has and the store has not applied, in the order they would run."""
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db import connections
    from django.db.migrations.executor import MigrationExecutor

    executor = MigrationExecutor(connections[using])
    plan = executor.migration_plan(executor.loader.graph.leaf_nodes())
    return [f"{migration.app_label}.{migration.name}" for migration, backwards in plan if not backwards]


def ensure_schema(using: str = "default") -> list[str]:
    """Apply pending migrations under the store's lock; returns the names applied (empty: none pending).

    Raises SchemaBehind when another process holds the lock for longer than ``LOCK_TIMEOUT``.
    """
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db import connections


    if not pending_migrations(using):
        return []
    if connections[using].vendor == "postgresql":
        return _migrate_on_server(using)
    try:
        with workspace().lock(LOCK_NAME, timeout=LOCK_TIMEOUT):
            return _migrate(using)
    except Timeout:
        raise SchemaBehind(f"another process has been migrating the store for {LOCK_TIMEOUT} s (lock "
                           f"{workspace().locks / LOCK_NAME}.lock); wait for it or run "
                           "'python manage.py migrate'") from None


def _migrate(using: str) -> list[str]:
    # the store's models (Django) load once Django is set up (harness.store)
    from django.core.management import call_command

    # another process may have migrated while this one waited for the lock
    pending = pending_migrations(using)
    if pending:
        call_command("migrate", database=using, interactive=False, verbosity=0)
    return pending


def _migrate_on_server(using: str) -> list[str]:
    # the store's models (Django) load once Django is set up (harness.store)
    from django.db import connections

    with connections[using].cursor() as cursor:
        cursor.execute("SET lock_timeout = %s", [f"{LOCK_TIMEOUT}s"])
        cursor.execute("SELECT pg_advisory_lock(%s)", [ADVISORY_LOCK])
        try:
            return _migrate(using)
        finally:
            cursor.execute("SELECT pg_advisory_unlock(%s)", [ADVISORY_LOCK])
