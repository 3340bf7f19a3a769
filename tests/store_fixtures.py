"""The throw-away store of the tests that open it in-process (tests/harness, tests/builds): ``HARNESS_HOME``
points at a temporary folder before Django is configured, so neither these tests nor the CLI they start ever
touch a user's store."""
import os
import shutil
import tempfile

import pytest


def store_fixtures(prefix: str):
    """The fixtures ``django_store`` (the store set up once per session, its folder removed afterwards) and
    ``store`` (emptied for each test, builds and run folders under ``tmp_path/home``) over a new temporary
    ``HARNESS_HOME`` named ``prefix...``; a conftest assigns them to module names of the same names."""
    home = tempfile.mkdtemp(prefix=prefix)
    os.environ["HARNESS_HOME"] = home
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "harness.settings")

    @pytest.fixture(scope="session")
    def django_store():
        from harness.store import (
            setup_store,  # after HARNESS_HOME is set: the store's settings read it
        )

        setup_store()
        yield
        shutil.rmtree(home, ignore_errors=True)

    @pytest.fixture
    def store(django_store, tmp_path, monkeypatch):
        """An empty store, emptied again afterwards; builds and run folders of this test under ``tmp_path/home``.
        Emptied both ways because a process may open the dashboard's test database first (tests/web/conftest.py,
        when a pytest-xdist worker takes a module of tests/web before this one): rows left in it would then meet
        the dashboard's test classes, which create their own targets and machines under the same names."""
        from harness.store.models import (  # Django is set up by django_store
            Machine,
            Target,
            TestCase,
        )

        def empty():
            Machine.objects.all().delete()
            Target.objects.all().delete()
            TestCase.objects.all().delete()

        empty()
        monkeypatch.setenv("HARNESS_HOME", str(tmp_path / "home"))
        yield tmp_path
        empty()

    return django_store, store
