"""Django settings of the store alone (the CLI uses these; webfrontend.settings extends them).

SQLite in ``$HARNESS_HOME/harness.sqlite3`` by default; PostgreSQL (or any Django backend) when
``HARNESS_DATABASE_URL`` is set, e.g. ``postgresql://user:pass@host:5432/dbname``.
"""
import os
from urllib.parse import urlparse, unquote

from harness.workspace import workspace

SECRET_KEY = os.environ.get("HARNESS_SECRET_KEY", "dev-only-not-secret-change-me-in-production-0123456789")
USE_TZ = True
TIME_ZONE = "UTC"
DEFAULT_AUTO_FIELD = "django.db.models.BigAutoField"

INSTALLED_APPS = [
    "django.contrib.auth",
    "django.contrib.contenttypes",
    "harness",
]


def _database_from_url(url: str) -> dict:
    parsed = urlparse(url)
    engines = {"postgres": "postgresql", "postgresql": "postgresql", "sqlite": "sqlite3"}
    scheme = parsed.scheme.split("+")[0]
    if scheme not in engines:
        raise ValueError(f"HARNESS_DATABASE_URL: unsupported scheme {parsed.scheme!r}")
    if scheme == "sqlite":
        return {"ENGINE": "django.db.backends.sqlite3", "NAME": unquote(parsed.path)}
    return {
        "ENGINE": "django.db.backends.postgresql",
        "NAME": unquote(parsed.path.lstrip("/")),
        "USER": unquote(parsed.username or ""),
        "PASSWORD": unquote(parsed.password or ""),
        "HOST": parsed.hostname or "",
        "PORT": str(parsed.port or ""),
    }


if os.environ.get("HARNESS_DATABASE_URL"):
    DATABASES = {"default": _database_from_url(os.environ["HARNESS_DATABASE_URL"])}
else:
    workspace().home.mkdir(parents=True, exist_ok=True)
    DATABASES = {
        "default": {
            "ENGINE": "django.db.backends.sqlite3",
            "NAME": str(workspace().database),
            # Several harness processes (run, check, import, serve) share one file. WAL lets readers go on
            # while one writes; IMMEDIATE takes the write lock when a transaction starts, so two writers
            # queue on the busy timeout instead of one failing at once with "database is locked" when
            # it upgrades a read lock.
            "OPTIONS": {"timeout": 120, "transaction_mode": "IMMEDIATE",
                        "init_command": "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;"},
        }
    }
