"""``harness serve``: the dashboard over the store (``python manage.py runserver`` with a migrated store).

The server runs in a child process with the dashboard settings (webfrontend.settings), so it does not
depend on how the CLI configured Django for itself.
"""
from __future__ import annotations

import os
import subprocess
import sys

from harness.workspace import PROJECT_ROOT

NAME = "serve"
HELP = "serve the web dashboard over the store (development server)"


def configure(parser) -> None:
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    parser.add_argument("--port", type=int, default=8000, help="port (default 8000)")
    parser.add_argument("--reload", action="store_true", help="restart when the code changes")


def command(args, *django_args: str) -> list[str]:
    """The ``python -m django`` command line with the dashboard settings."""
    return [sys.executable, "-m", "django", *django_args, "--settings", "webfrontend.settings"]


def run(args) -> int:
    env = dict(os.environ)
    # the project folder on the path even without `pip install -e .`
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(PROJECT_ROOT), env.get("PYTHONPATH", "")) if p)
    migrate = subprocess.run(command(args, "migrate", "--verbosity", "0"), env=env)
    if migrate.returncode != 0:
        return migrate.returncode
    print(f"dashboard on http://{args.host}:{args.port}/ (Ctrl-C stops it)", flush=True)
    extra = [] if args.reload else ["--noreload"]
    try:
        return subprocess.run(command(args, "runserver", f"{args.host}:{args.port}", *extra), env=env).returncode
    except KeyboardInterrupt:
        return 0
