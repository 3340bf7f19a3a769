"""Bringing the store's schema up to date when a program opens it (the dashboard's servers, createsuperuser).

The embedded store (SQLite, one file on this machine) is migrated on open, under the workspace lock
``migrate`` - the one the CLI's ``harness.store.setup_store`` takes - so that two servers, or a server and
a harness command, starting at once on a new workspace do not both migrate it. Any other database (PostgreSQL, possibly shared by several machines, where a
file lock protects nothing) is never migrated behind the user's back: ``SchemaBehind`` names the command.
"""
from __future__ import annotations

#: name of the workspace lock held while migrating (harness.workspace.Workspace.lock)
LOCK_NAME = "migrate"
#: seconds to wait for another process that is migrating the same store
LOCK_TIMEOUT = 600


class SchemaBehind(Exception):
    """The store's schema is older than this code and is not migrated here; the message names the command."""


def pending_migrations(using: str = "default") -> list[str]:
    """``app.migration`` names this code has and the store has not applied, in the order they would run."""
    from django.db import connections
    from django.db.migrations.executor import MigrationExecutor

    executor = MigrationExecutor(connections[using])
    plan = executor.migration_plan(executor.loader.graph.leaf_nodes())
    return [f"{migration.app_label}.{migration.name}" for migration, backwards in plan if not backwards]


def ensure_schema(using: str = "default") -> list[str]:
    """Apply pending migrations to an SQLite store (under the lock); returns the names applied.

    Raises SchemaBehind for other databases with pending migrations, naming the command that applies them.
    """
    from django.core.management import call_command
    from django.db import connections
    from filelock import Timeout

    from harness.workspace import workspace

    pending = pending_migrations(using)
    if not pending:
        return []
    if connections[using].vendor != "sqlite":
        raise SchemaBehind(f"the store's schema is older than this dashboard ({len(pending)} migration(s) to "
                           f"apply, first {pending[0]}): run 'python manage.py migrate' once, then start "
                           "the server again")
    try:
        with workspace().lock(LOCK_NAME, timeout=LOCK_TIMEOUT):
            # another process may have migrated while this one waited for the lock
            pending = pending_migrations(using)
            if pending:
                call_command("migrate", database=using, interactive=False, verbosity=0)
    except Timeout:
        raise SchemaBehind(f"another process has been migrating the store for {LOCK_TIMEOUT} s (lock "
                           f"{workspace().locks / LOCK_NAME}.lock); wait for it or run "
                           "'python manage.py migrate'") from None
    return pending
