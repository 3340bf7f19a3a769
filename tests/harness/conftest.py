"""Fixtures for the harness tests: a throw-away store, temporary git repositories, a fake engine.

``HARNESS_HOME`` points at a temporary folder before Django is configured, so neither these tests nor the
CLI they start ever touch a user's store.
"""
import os
import shutil
import tempfile
from pathlib import Path

import pytest

_HOME = tempfile.mkdtemp(prefix="harness-tests-")
os.environ["HARNESS_HOME"] = _HOME
os.environ.setdefault("DJANGO_SETTINGS_MODULE", "harness.settings")

FAKE_ENGINE = Path(__file__).parent / "fake_engine" / "__main__.py"


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


def git_repo(folder: Path):
    import git

    folder.mkdir(parents=True, exist_ok=True)
    repo = git.Repo.init(folder)
    with repo.config_writer() as config:
        config.set_value("user", "name", "Test")
        config.set_value("user", "email", "test@example.org")
    return repo


def commit_files(repo, files: dict, message: str, tag: str | None = None) -> str:
    """Write ``{relative path: text}`` (``None`` deletes) and commit; returns the commit id."""
    root = Path(repo.working_tree_dir)
    for rel, text in files.items():
        path = root / rel
        if text is None:
            path.unlink()
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        if rel.startswith("scripts/") or rel.endswith(".sh") or "/scripts/" in rel:
            path.chmod(0o755)
    repo.git.add("-A")
    repo.index.commit(message)
    if tag:
        repo.create_tag(tag)
    return repo.head.commit.hexsha


def fake_engine_source(gravity: float = 9.81) -> str:
    """The fake engine's source with gravity ``gravity`` m/s^2 (another value = an inconsistent revision)."""
    text = FAKE_ENGINE.read_text()
    return text.replace("G = 9.81  #", f"G = {gravity!r}  #")
