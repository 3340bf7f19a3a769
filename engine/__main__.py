"""``python -m engine -in SCRIPT [-var NAME VALUE]... [-log FILE]`` (console script ``dem``).

Exit codes: 0 success, 2 bad input, 1 runtime failure. Errors are one ``ERROR: ...`` line on stderr and
at the end of the log; timing.json and all outputs written so far are left valid.
"""
from __future__ import annotations

import sys

USAGE = "usage: dem -in SCRIPT [-var NAME VALUE]... [-log FILE]"


def parse_args(argv):
    script, log, variables = None, "log.dem", {}
    i = 0
    while i < len(argv):
        flag = argv[i]
        if flag in ("-in", "-i") and i + 1 < len(argv):
            script = argv[i + 1]
            i += 2
        elif flag in ("-log", "-l") and i + 1 < len(argv):
            log = argv[i + 1]
            i += 2
        elif flag in ("-var", "-v") and i + 2 < len(argv):
            variables[argv[i + 1]] = argv[i + 2]
            i += 3
        else:
            raise ValueError(f"bad command line argument '{flag}' ({USAGE})")
    if script is None:
        raise ValueError(f"no input script ({USAGE})")
    return script, log, variables


def run(script: str, log_path: str | None, variables: dict, echo: bool = True) -> int:
    """Run a script in the current folder; returns the exit code."""
    from .errors import InputError, RunFailure
    from .script import load_script, substitute
    from .simulation import Log, Simulation
    from .writers import write_timing

    log = Log(log_path, echo=echo)
    sim = Simulation(log)
    code = 0
    try:
        commands = load_script(script, variables)
        for index, raw in enumerate(commands, start=1):
            where = f"{script}: command {index}"
            if not isinstance(raw, dict) or "command" not in raw:
                raise InputError(f"{where}: must be an object with a 'command' field")
            sim.execute(substitute(raw, variables, f"{where} ({raw.get('command')})"), index, script)
        log.info(f"total: {sim.timing['steps']} steps, {len(sim.pid)} particles, {log.warnings} warning(s)")
    except (InputError, RunFailure) as exc:
        code = exc.exit_code
        message = f"ERROR: {exc}"
        log.info(message)
        if not echo or log.handle is None:
            pass
        print(message, file=sys.stderr, flush=True)
    finally:
        sim.close()
        try:
            write_timing("timing.json", sim.timing_record())
        finally:
            log.close()
    return code


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        script, log, variables = parse_args(argv)
    except ValueError as exc:
        print(f"ERROR: {exc}", file=sys.stderr)
        return 2
    return run(script, log, variables)


if __name__ == "__main__":
    sys.exit(main())
