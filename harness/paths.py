"""Where the harness keeps its workspace: the store, cached builds and run folders.

``HARNESS_HOME`` chooses the workspace folder; by default it is ``.harness`` in the project checkout.
"""
import os
from pathlib import Path

PROJECT_ROOT = Path(__file__).resolve().parent.parent


def harness_home() -> Path:
    home = os.environ.get("HARNESS_HOME")
    path = Path(home).expanduser() if home else PROJECT_ROOT / ".harness"
    return path.resolve()


def builds_dir() -> Path:
    return harness_home() / "builds"


def runs_dir() -> Path:
    return harness_home() / "runs"


def database_path() -> Path:
    return harness_home() / "harness.sqlite3"
