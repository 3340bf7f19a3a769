"""Helpers for the harness tests: temporary git repositories and the fake engine's source."""
from pathlib import Path

FAKE_ENGINE = Path(__file__).parent / "fake_engine" / "__main__.py"


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
