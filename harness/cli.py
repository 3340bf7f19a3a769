"""The ``harness`` command line: ``harness [--machine NAME] [--home DIR] COMMAND ...``.

Subcommands live in ``harness/commands/`` (one module each, found with pkgutil). A ``UserError`` becomes
one line ``harness: error: ...`` and exit code 1; nothing a user can cause prints a traceback. Nor does a
fault of the machine: a workspace that is not a folder or cannot be created, a store that cannot be opened
or written (``harness: error: store FILE: MESSAGE`` - read-only, disk full, server down; what was stored
before stays), a file that cannot be read or written (``harness: error: FILE: MESSAGE``). Set
``HARNESS_TRACEBACK=1`` to see the traceback of such a fault instead.
"""
from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import signal
import socket
import sys
import threading
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import harness.commands as package
from harness.adapters.base import UserError
from harness.execution.workspace import (
    Workspace,
    segment_problem,
    use_workspace,
    workspace,
)
from harness.report import textout


def _commands():

    found = []
    for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"harness.commands.{info.name}")
        if all(hasattr(module, attr) for attr in ("NAME", "HELP", "configure", "run")):
            found.append(module)
    return found


def _global_options(parser, defaults: bool) -> None:
    """--machine, --home, --targets: before the subcommand (with defaults) or after it (overriding them)."""
    def default(value):
        return value if defaults else argparse.SUPPRESS

    parser.add_argument("--machine", default=default(os.environ.get("HARNESS_MACHINE") or socket.gethostname()),
                        help="machine name runs are recorded under (default: $HARNESS_MACHINE, else hostname)")
    parser.add_argument("--home", default=default(None), help="workspace folder: store, builds, runs (default: "
                        "$HARNESS_HOME, else .harness/ in the project)")
    parser.add_argument("--targets", dest="targets_dir", default=default(None), help="folder of target "
                        "definitions (default: $HARNESS_TARGETS, else targets/ of the project)")
    parser.add_argument("--wide", action="store_true", default=default(False),
                        help="print tables whole, however wide (default: they fit 120 columns)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="harness", description="Regression and acceptance test harness "
                                     "for DEM codes (build targets, run test cases, check consistency).")
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    _global_options(parser, defaults=True)
    after = argparse.ArgumentParser(add_help=False)
    _global_options(after, defaults=False)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in _commands():
        command = sub.add_parser(module.NAME, help=module.HELP, description=module.HELP, parents=[after])
        module.configure(command)
        command.set_defaults(_run=module.run)
    return parser


def _version() -> str:

    try:
        return version("dem-harness")
    except PackageNotFoundError:
        return "unknown (not installed)"


def _terminate(signum, frame):
    # SIGTERM (a CI job cancelled, kill) takes the same path as Ctrl-C: runs in flight are recorded
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    args_list = sys.argv[1:] if argv is None else list(argv)
    # the workspace is chosen before any subcommand configures the store in it
    pre = argparse.ArgumentParser(add_help=False)
    pre.add_argument("--home")
    known, _ = pre.parse_known_args(args_list)
    ws = Workspace.at(known.home) if known.home else Workspace.from_environment()
    with use_workspace(ws):
        return _dispatch(args_list)


def _dispatch(args_list: list[str]) -> int:
    parser = build_parser()
    args = parser.parse_args(args_list)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    problem = segment_problem(args.machine)
    if problem:
        print(f"harness: error: --machine: {problem}", file=sys.stderr)
        return 1
    if args.targets_dir:
        args.targets_dir = Path(args.targets_dir).expanduser().resolve()
    problem = _workspace_problem(workspace().home)
    if problem:
        print(f"harness: error: {problem}", file=sys.stderr)
        return 1
    previous = signal.signal(signal.SIGTERM, _terminate) if _in_main_thread() else None
    textout.set_width(None if args.wide else textout.DEFAULT_WIDTH)
    try:
        return int(args._run(args) or 0)
    except UserError as exc:
        print(f"harness: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("harness: interrupted; runs in flight were recorded as failed (interrupted)", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - only a fault of the machine is mapped; anything else re-raised
        line = _fault_line(exc)
        if line is None or os.environ.get("HARNESS_TRACEBACK"):
            raise
        print(f"harness: error: {line}", file=sys.stderr)
        return 1
    finally:
        textout.set_width(textout.DEFAULT_WIDTH)
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _workspace_problem(home: Path) -> str | None:
    """Why the workspace folder cannot be used (None: it exists or was created)."""
    if home.exists() and not home.is_dir():
        return f"workspace {home}: not a folder (--home or HARNESS_HOME)"
    try:
        home.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return f"workspace {home}: cannot create ({exc.strerror or exc})"
    return None


def _fault_line(exc: BaseException) -> str | None:
    """One line for a fault of the machine rather than of the harness: the store cannot be opened or
    written (a Django DatabaseError: read-only, full disk, server down), or a file cannot be read or written
    (an OSError). None for anything else (a bug, shown with its traceback)."""
    if "django.db" in sys.modules:
        # the store's models (Django) load once Django is set up (harness.store)
        from django.db import DatabaseError

        if isinstance(exc, DatabaseError):
            return f"store {_store_name()}: {' '.join(str(exc).split()) or type(exc).__name__}" \
                   f"{_sqlite_folder_fault()}"
    if isinstance(exc, OSError):
        what = exc.strerror or str(exc) or type(exc).__name__
        return f"{exc.filename}: {what}" if exc.filename else what
    return None


def _sqlite_folder_fault() -> str:
    """'; its folder F is read-only' when the SQLite store's folder cannot be written (SQLite keeps its journal
    beside the file, so a read-only folder makes even a writable file fail, with "unable to open database
    file" or "attempt to write a readonly database"); '' otherwise."""
    database = _store_settings()
    if database is None or not database["ENGINE"].endswith("sqlite3"):
        return ""
    folder = Path(str(database["NAME"])).parent
    # access(2) answers EROFS for a read-only file system even to root, whom file modes do not stop
    return f"; its folder {folder} is read-only" if folder.is_dir() and not os.access(folder, os.W_OK) else ""


def _store_settings() -> dict | None:
    """Django's settings of the store's database, None before Django is configured."""
    try:
        # the store's models (Django) load once Django is set up (harness.store)
        from django.conf import settings

        return settings.DATABASES["default"]
    except Exception:  # noqa: BLE001 - settings not configured
        return None


def _store_name() -> str:
    """The SQLite file, or ENGINE HOST:PORT/NAME of a database server (never its password)."""
    database = _store_settings()
    if database is None:   # name what the workspace would use
        return str(workspace().database)
    if database["ENGINE"].endswith("sqlite3"):
        return str(database["NAME"])
    return f"{database['ENGINE'].rsplit('.', 1)[-1]} {database.get('HOST') or 'localhost'}" \
           f"{':' + str(database['PORT']) if database.get('PORT') else ''}/{database['NAME']}"


def _in_main_thread() -> bool:

    return threading.current_thread() is threading.main_thread()


if __name__ == "__main__":
    sys.exit(main())
