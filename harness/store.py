"""Open the store from outside Django (the CLI, scripts): configure settings once and migrate."""
import os

_ready = False
#: key of the PostgreSQL advisory lock held while migrating (any constant the harness alone uses)
MIGRATION_LOCK = 0x64656D68


def setup_store(migrate: bool = True) -> None:
    """Configure Django with the store settings (unless already configured) and bring the schema up to date.

    A bad ``HARNESS_DATABASE_URL`` or a missing database driver is a one-line UserError. Migrations of an
    embedded SQLite store run under a workspace lock, so that harness processes starting together on a new
    workspace do not migrate it twice.
    """
    global _ready
    if _ready:
        return
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "harness.settings")
    import django
    from django.core.exceptions import ImproperlyConfigured
    from django.core.management import call_command

    from harness.adapters.base import UserError
    from harness.workspace import workspace

    try:
        django.setup()
    except ValueError as exc:  # harness.settings.database_from_url
        raise UserError(str(exc)) from None
    except ImproperlyConfigured as exc:
        if "psycopg" in str(exc):
            raise UserError("HARNESS_DATABASE_URL names a PostgreSQL store, but no PostgreSQL driver is "
                            "installed (pip install -e '.[postgresql]')") from None
        raise UserError(f"store settings: {exc}") from None
    if migrate:
        from django.conf import settings

        if settings.DATABASES["default"]["ENGINE"].endswith("sqlite3"):
            with workspace().lock("migrate"):
                call_command("migrate", verbosity=0, interactive=False)
        else:
            from django.db import connection

            # a server store: an advisory lock serialises harness processes on several machines migrating it
            with connection.cursor() as cursor:
                cursor.execute("SELECT pg_advisory_lock(%s)", [MIGRATION_LOCK])
                try:
                    call_command("migrate", verbosity=0, interactive=False)
                finally:
                    cursor.execute("SELECT pg_advisory_unlock(%s)", [MIGRATION_LOCK])
    _ready = True
