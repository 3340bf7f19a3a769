"""Open the store from outside Django (the CLI, scripts): configure settings once and migrate."""
import os

from harness.adapters.base import UserError

_ready = False


def setup_store(migrate: bool = True) -> None:
    """Configure Django with the store settings (unless already configured) and bring the schema up to date.

    A bad ``HARNESS_DATABASE_URL`` or a missing database driver is a one-line UserError. Migrations run
    under the store's lock (``harness.store.schema.ensure_schema``), shared with the dashboard.
    """
    global _ready
    if _ready:
        return
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "harness.settings")
    # the store's models (Django) load once Django is set up (harness.store)
    import django
    from django.core.exceptions import ImproperlyConfigured


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
        # the store's models (Django) load once Django is set up (harness.store)
        from harness.store.schema import SchemaBehind, ensure_schema

        try:
            ensure_schema()
        except SchemaBehind as exc:
            raise UserError(f"store: {exc}") from None
        except ImproperlyConfigured as exc:  # what only the database backend checks, as it connects
            raise UserError(f"HARNESS_DATABASE_URL: {str(exc).splitlines()[0]}") from None
    _ready = True
