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

from harness.adapters.base import UserError


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
    parser.add_argument("--home", help="workspace folder: store, builds, runs (sets HARNESS_HOME)")
    parser.add_argument("--targets", help="folder of target definitions (default: targets/ of the project; "
                        "sets HARNESS_TARGETS)")
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
    # --home must be applied before the store's settings are imported by any subcommand
    args_list = sys.argv[1:] if argv is None else list(argv)
    pre = argparse.ArgumentParser(add_help=False)
    pre.add_argument("--home")
    pre.add_argument("--targets")
    known, _ = pre.parse_known_args(args_list)
    # main() also runs in-process (tests, scripts): put the environment back afterwards
    saved = {name: os.environ.get(name) for name in ("HARNESS_HOME", "HARNESS_TARGETS")}
    try:
        if known.home:
            os.environ["HARNESS_HOME"] = os.path.abspath(os.path.expanduser(known.home))
        if known.targets:
            os.environ["HARNESS_TARGETS"] = os.path.abspath(os.path.expanduser(known.targets))
        return _dispatch(args_list)
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _dispatch(args_list: list[str]) -> int:
    parser = build_parser()
    args = parser.parse_args(args_list)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
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
