"""Django for the dashboard tests: webfrontend settings and a throw-away test database.

The test database is a fresh file (SQLite) or ``test_<name>`` (PostgreSQL) - never the user's store.
"""
import os

import pytest

# webfrontend.settings is a superset of harness.settings, so the other test folders work with it too;
# the variable is put back afterwards, so programs other tests start keep the settings they expect
_previous = os.environ.get("DJANGO_SETTINGS_MODULE")
os.environ["DJANGO_SETTINGS_MODULE"] = "webfrontend.settings"

import django  # noqa: E402
from django.conf import settings  # noqa: E402

django.setup()
if _previous is None:
    del os.environ["DJANGO_SETTINGS_MODULE"]
else:
    os.environ["DJANGO_SETTINGS_MODULE"] = _previous
if "webfrontend" not in settings.INSTALLED_APPS:
    raise pytest.UsageError("Django was configured before tests/web with settings lacking the dashboard; "
                            "use DJANGO_SETTINGS_MODULE=webfrontend.settings (a superset of harness.settings)")


@pytest.fixture(scope="session", autouse=True)
def dashboard_test_database(tmp_path_factory):
    from django.db import connection
    from django.test.utils import setup_test_environment, teardown_test_environment

    setup_test_environment()
    if connection.vendor == "sqlite":
        # a file, not :memory:, so the live server thread of the browser test sees the same data
        connection.settings_dict.setdefault("TEST", {})["NAME"] = str(
            tmp_path_factory.mktemp("store") / "test.sqlite3")
    old_name = connection.creation.create_test_db(verbosity=0, autoclobber=True)
    yield
    connection.creation.destroy_test_db(old_name, verbosity=0)
    teardown_test_environment()
