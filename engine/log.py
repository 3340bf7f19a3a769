"""The run log (and its echo on stdout): commands, WARNING lines, run summaries, a final ERROR line.

Kept apart from the simulation so that `engine.__main__` can open it, and report a log that cannot be
opened, before numpy and numba are imported.
"""
from __future__ import annotations

import os
import sys

from .errors import InputError, RunFailure


class Log:
    """The log file (and stdout). A failed write (disk full, I/O error) closes the file and raises RunFailure
    once; later lines still go to stdout, so the final ERROR line is not lost."""

    def __init__(self, path: str | None, echo: bool = True):
        self.path = path
        self.echo = echo
        self.warnings = 0
        self.handle = None
        if path:
            try:
                self.handle = open(path, "w", buffering=1, encoding="utf-8")
            except OSError as exc:
                # a path given on the command line that cannot be a file: bad input, like a missing script
                raise InputError(f"cannot open log file {path}: {exc.strerror or exc}") from None

    def info(self, text: str):
        if self.echo:
            try:
                print(text, flush=True)
            except (OSError, ValueError):  # stdout closed or a pipe whose reader left: the file is the record
                self.echo = False
                _silence_stdout()
        if self.handle is not None:
            try:
                self.handle.write(text + "\n")
                self.handle.flush()
            except OSError as exc:
                self._drop()
                raise RunFailure(f"cannot write log file {self.path}: {exc.strerror or exc}") from None

    def warning(self, text: str):
        self.warnings += 1
        self.info("WARNING: " + text)

    def _drop(self):
        """Forget a broken file; closing it retries the buffered write, which fails again: ignore that."""
        handle, self.handle = self.handle, None
        try:
            handle.close()
        except OSError:
            pass

    def close(self):
        if self.handle is not None:
            self._drop()


def _silence_stdout():
    """Point stdout at /dev/null so that the interpreter's final flush does not complain about a broken pipe."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


def stderr_line(text: str):
    """One line on stderr; a closed or broken stderr must not turn an error report into a traceback."""
    try:
        print(text, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass
