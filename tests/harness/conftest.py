"""Fixtures for the harness tests: a throw-away store, temporary git repositories, a fake engine.

``HARNESS_HOME`` points at a temporary folder before Django is configured, so neither these tests nor the
CLI they start ever touch a user's store.
"""
import os
import shutil
import tempfile

import pytest

_HOME = tempfile.mkdtemp(prefix="harness-tests-")
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
    """An empty store; builds and run folders of this test under ``tmp_path/home``."""
    from harness.models import Machine, Target, TestCase

    Machine.objects.all().delete()
    Target.objects.all().delete()
    TestCase.objects.all().delete()
    monkeypatch.setenv("HARNESS_HOME", str(tmp_path / "home"))
    return tmp_path
