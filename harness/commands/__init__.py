"""Subcommands of the ``harness`` CLI, one module each, discovered by ``harness.cli``.

Each module defines ``NAME``, ``HELP``, ``configure(parser)`` and ``run(args) -> int`` (the exit code);
the real work is a library function the tests and the dashboard can call too.
"""
