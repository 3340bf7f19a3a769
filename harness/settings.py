"""Django settings of the store alone (the CLI uses these; webfrontend.settings extends them).

SQLite in ``<workspace>/harness.sqlite3`` by default; PostgreSQL when ``HARNESS_DATABASE_URL`` is set, e.g.
``postgresql://user:pass@host:5432/dbname`` or ``postgresql://user@/dbname?host=/run/postgresql`` (a Unix
socket), which needs the optional ``psycopg`` (``pip install -e .[postgresql]``).
"""
import os

from harness.execution.workspace import workspace

SECRET_KEY = os.environ.get("HARNESS_SECRET_KEY", "dev-only-not-secret-change-me-in-production-0123456789")
USE_TZ = True
TIME_ZONE = "UTC"
DEFAULT_AUTO_FIELD = "django.db.models.BigAutoField"

INSTALLED_APPS = [
    "django.contrib.auth",
    "django.contrib.contenttypes",
    "harness.store.apps.HarnessConfig",  # app label "harness": the tables and migrations of every store
]


#: SQLite: several harness processes (run, check, import, serve) share one file. WAL lets readers go on while
#: one writes; IMMEDIATE takes the write lock when a transaction starts, so two writers queue on the busy
#: timeout instead of one failing at once with "database is locked" when it upgrades a read lock.
SQLITE_OPTIONS = {"timeout": 120, "transaction_mode": "IMMEDIATE",
                  "init_command": "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;"}


def database_from_url(url: str) -> dict:
    """Django's DATABASES entry for a URL, parsed by dj-database-url: ``postgresql://user:pass@host:5432/db``,
    a Unix socket ``postgresql://user@/db?host=/run/postgresql``, or ``sqlite:////path/store.sqlite3``."""
    # only a HARNESS_DATABASE_URL needs it
    import dj_database_url

    example = "postgresql://user@host:5432/dbname or sqlite:////path/store.sqlite3"
    if "://" not in url:
        raise ValueError(f"HARNESS_DATABASE_URL: not a database URL ({example})")
    try:
        config = dj_database_url.parse(url)
    except ValueError as exc:
        if str(exc).startswith("Scheme"):
            raise ValueError(f"HARNESS_DATABASE_URL: unknown scheme {url.split('://', 1)[0][:20]!r} "
                             f"({example})") from None
        raise ValueError(f"HARNESS_DATABASE_URL: {exc}") from None
    if config["ENGINE"] not in ("django.db.backends.postgresql", "django.db.backends.sqlite3"):
        raise ValueError(f"HARNESS_DATABASE_URL: unsupported database {config['ENGINE'].rsplit('.', 1)[-1]!r} "
                         "(postgresql or sqlite)")
    if config["ENGINE"].endswith("postgresql") and not config.get("NAME") \
            and not (config.get("OPTIONS") or {}).get("service"):
        raise ValueError("HARNESS_DATABASE_URL: names no database (postgresql://user@host:5432/DBNAME)")
    if config["ENGINE"].endswith("sqlite3") and config.get("NAME") in (None, "", ":memory:"):
        raise ValueError("HARNESS_DATABASE_URL: names no database file (an in-memory store keeps nothing; "
                         "sqlite:////absolute/path/store.sqlite3)")
    if config["ENGINE"].endswith("sqlite3"):
        config["OPTIONS"] = {**SQLITE_OPTIONS, **config.get("OPTIONS", {})}
    return config


if os.environ.get("HARNESS_DATABASE_URL"):
    try:
        DATABASES = {"default": database_from_url(os.environ["HARNESS_DATABASE_URL"])}
    except ValueError as exc:  # one line for the CLI, manage.py, the dashboard's servers alike: no traceback
        raise SystemExit(f"harness: error: {exc}") from None
else:
    workspace().home.mkdir(parents=True, exist_ok=True)
    DATABASES = {"default": {"ENGINE": "django.db.backends.sqlite3", "NAME": str(workspace().database),
                             "OPTIONS": SQLITE_OPTIONS}}
