"""The ``harness`` command line: ``harness [--machine NAME] [--home DIR] COMMAND ...``.

Subcommands live in ``harness/commands/`` (one module each, found with pkgutil). A ``UserError`` becomes
one line ``harness: error: ...`` and exit code 1; nothing a user can cause prints a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import signal
import socket
import sys

from pathlib import Path

from harness.adapters.base import UserError
from harness.workspace import Workspace, segment_problem, use_workspace


def _commands():
    import harness.commands as package

    found = []
    for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"harness.commands.{info.name}")
        if all(hasattr(module, attr) for attr in ("NAME", "HELP", "configure", "run")):
            found.append(module)
    return found


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="harness", description="Regression and acceptance test harness "
                                     "for DEM codes (build targets, run test cases, check consistency).")
    parser.add_argument("--machine", default=os.environ.get("HARNESS_MACHINE") or socket.gethostname(),
                        help="machine name runs are recorded under (default: hostname)")
    parser.add_argument("--home", help="workspace folder: store, builds, runs (default: $HARNESS_HOME, "
                        "else .harness/ in the project)")
    parser.add_argument("--targets", dest="targets_dir", help="folder of target definitions (default: "
                        "$HARNESS_TARGETS, else targets/ of the project)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in _commands():
        command = sub.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.configure(command)
        command.set_defaults(_run=module.run)
    return parser


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
    previous = signal.signal(signal.SIGTERM, _terminate) if _in_main_thread() else None
    try:
        return int(args._run(args) or 0)
    except UserError as exc:
        print(f"harness: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("harness: interrupted; runs in flight were recorded as failed (interrupted)", file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _in_main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


if __name__ == "__main__":
    sys.exit(main())
