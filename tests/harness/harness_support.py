"""Helpers for the harness tests: the fake engine's source (git repositories: tests/harness_process.py)."""
from pathlib import Path

from harness_process import commit_files, git_repo  # noqa: F401  (the harness tests import them from here)

FAKE_ENGINE = Path(__file__).parent / "fake_engine" / "__main__.py"


def fake_engine_source(gravity: float = 9.81, stepping: list[float] | None = None) -> str:
    """The fake engine's source with gravity ``gravity`` m/s^2 (another value = an inconsistent revision) and
    the loop times ``stepping`` (s) its successive runs in one folder report, in turn (default: 2 ms)."""
    text = FAKE_ENGINE.read_text().replace("G = 9.81  #", f"G = {gravity!r}  #")
    return text.replace("STEPPING = [0.002]  #", f"STEPPING = {stepping!r}  #") if stepping else text
