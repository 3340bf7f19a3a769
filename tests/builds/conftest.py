"""(The folder is `builds`, not `build`: pytest does not collect folders named build.) Fixtures for the build tests: a throw-away store (as tests/harness/conftest.py), tiny C++ repositories,
and one ccache folder shared by the slow LIGGGHTS builds of a session."""
import os
import shutil
import tempfile

import pytest

_HOME = tempfile.mkdtemp(prefix="harness-build-tests-")
os.environ["HARNESS_HOME"] = _HOME
os.environ.setdefault("DJANGO_SETTINGS_MODULE", "harness.settings")


@pytest.fixture(scope="session")
def django_store():
    from harness.store import setup_store

    setup_store()
    yield
    shutil.rmtree(_HOME, ignore_errors=True)


@pytest.fixture
def store(django_store, tmp_path, monkeypatch):
    """An empty store; builds of this test under ``tmp_path/home``."""
    from harness.models import Machine, Target, TestCase

    Machine.objects.all().delete()
    Target.objects.all().delete()
    TestCase.objects.all().delete()
    monkeypatch.setenv("HARNESS_HOME", str(tmp_path / "home"))
    return tmp_path


@pytest.fixture(scope="session")
def shared_ccache(tmp_path_factory):
    """One ccache folder for every slow LIGGGHTS build of the session: the second build of a commit next to
    a built one (or of the same commit in another workspace) compiles only what changed.
    ``HARNESS_TEST_CCACHE`` names a folder kept between sessions (a CI cache) instead of a fresh one."""
    kept = os.environ.get("HARNESS_TEST_CCACHE")
    return kept if kept else tmp_path_factory.mktemp("ccache")
