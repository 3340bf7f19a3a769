"""The two ways a run can fail; `engine.__main__` turns each into one ``ERROR:`` line and an exit code."""


class InputError(Exception):
    """Bad input the user can fix (unknown command, missing or mistyped field, unreadable file): exit code 2."""

    exit_code = 2


class RunFailure(Exception):
    """The simulation itself failed (non-finite values, time step above critical in strict mode, an output that
    cannot be written): exit code 1."""

    exit_code = 1


def output_failure(what: str, path, exc: OSError) -> RunFailure:
    """A file the run writes (thermo, print, dump, restart, timing) could not be written: names file and cause."""
    return RunFailure(f"cannot write {what} {path}: {exc.strerror or exc}")
