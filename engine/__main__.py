"""``python -m engine -in SCRIPT [-var NAME VALUE]... [-log FILE]`` (console script ``dem``).

Exit codes: 0 success, 2 bad input, 1 runtime failure. Errors are one ``ERROR: ...`` line on stderr and
at the end of the log; timing.json and all outputs written so far are left valid. No failure, expected or
not, reaches the user as a Python traceback: the specific cases are reported where they arise, and `run`
keeps a last-resort guard that turns anything else into one ERROR line naming the exception.
"""
from __future__ import annotations

import os
import sys
import traceback

from .errors import InputError, RunFailure
from .log import Log, stderr_line

USAGE = "usage: dem -in SCRIPT [-var NAME VALUE]... [-log FILE] [-threads N] | dem -cache | dem -cache-prune SIZE"

HELP = f"""{USAGE}
       python -m engine -in SCRIPT [-var NAME VALUE]... [-log FILE] [-threads N]
       dem -cache | dem -cache-prune SIZE

Run a DEM scene script (a JSON list of commands: create, get, set, fix, unfix, run) in the current folder.

options:
  -in, -i SCRIPT        the scene script (JSON, UTF-8)
  -var, -v NAME VALUE   fill ${{NAME}} in the script with VALUE (repeatable)
  -log, -l FILE         the log file (default log.dem); also echoed to stdout
  -threads, -t N        threads of the compiled loops (default: NUMBA_NUM_THREADS, else every core); the
                        results are bitwise the same for every N
  -h, --help            show this text and exit
  -cache                show the compiled-code cache ($DEM_CACHE_DIR, default ~/.cache/dem-engine): size,
                        entries, limit ($DEM_CACHE_LIMIT, default 1G: a run that compiled removes the least
                        recently used entries above it)
  -cache-prune SIZE     remove the least recently used entries now until the cache holds at most 80 % of SIZE
                        (e.g. 500M; 0 removes everything not used in the last hour)

outputs (current folder): the log, thermo.csv, print files, VTK dumps, restart files, timing.json

exit codes: 0 success; 2 bad input (script, fields, variables, paths); 1 the run failed (non-finite values,
critical time step exceeded in strict mode, every particle lost, an output that cannot be written).
A failure is one line 'ERROR: ...' on stderr and the last line of the log. See engine/README.md.
"""


def parse_args(argv):
    """(script, log, variables, threads), or None when help was asked for; ValueError on a bad command line."""
    script, log, variables, threads = None, "log.dem", {}, None
    i = 0
    while i < len(argv):
        flag = argv[i]
        if flag in ("-h", "-help", "--help"):
            return None
        if flag in ("-in", "-i") and i + 1 < len(argv):
            script = argv[i + 1]
            i += 2
        elif flag in ("-log", "-l") and i + 1 < len(argv):
            log = argv[i + 1]
            i += 2
        elif flag in ("-threads", "-t") and i + 1 < len(argv):
            try:
                threads = int(argv[i + 1])
            except ValueError:
                threads = 0
            if not 1 <= threads <= 4096:
                raise ValueError(f"-threads needs a whole number from 1 to 4096, got '{argv[i + 1]}' ({USAGE})")
            i += 2
        elif flag in ("-var", "-v") and i + 2 < len(argv):
            variables[argv[i + 1]] = argv[i + 2]
            i += 3
        else:
            raise ValueError(f"bad command line argument '{flag}' ({USAGE})")
    if script is None:
        raise ValueError(f"no input script ({USAGE})")
    return script, log, variables, threads


def _unexpected(exc: BaseException) -> tuple[int, str]:
    """(exit code, message) for an exception no specific handler turned into an InputError or RunFailure.

    The message names the exception type and, for a bug, the innermost engine source line: enough to start
    looking, without a traceback for the user.
    """
    detail = str(exc).splitlines()[0] if str(exc) else ""
    if isinstance(exc, MemoryError):
        return 1, f"out of memory ({type(exc).__name__}{': ' + detail if detail else ''}); fewer particles, or a " \
                  "machine with more memory"
    if isinstance(exc, RecursionError):
        return 2, f"input nested too deeply to process ({type(exc).__name__})"
    if isinstance(exc, OSError):
        path = f" {exc.filename}" if exc.filename else ""
        return 1, f"file system error{path}: {exc.strerror or exc} ({type(exc).__name__})"
    frames = traceback.extract_tb(exc.__traceback__)
    where = next((f"{os.path.basename(f.filename)}:{f.lineno}" for f in reversed(frames)
                  if os.sep + "engine" + os.sep in f.filename), None)
    return 1, (f"internal error {type(exc).__name__}{': ' + detail if detail else ''}"
               f"{f' (at {where})' if where else ''}; please report it with the script")


def run(script: str, log_path: str | None, variables: dict, threads: int | None = None, echo: bool = True) -> int:
    """Run a script in the current folder with `threads` threads (None: NUMBA_NUM_THREADS or every core);
    returns the exit code."""
    log = sim = None
    code = 0
    message = None
    where = script  # the command being executed, for messages of unexpected failures
    try:
        log = Log(log_path, echo=echo)
        # imported once the log is open (a broken build is reported there), and numba only after
        # threads.configure has set NUMBA_NUM_THREADS
        from . import threads as thread_pool

        thread_pool.configure(threads)
        from . import cache_limit

        cache_limit.limit()  # a bad DEM_CACHE_LIMIT is an input error before anything runs
        import numpy as np

        from .script import load_script, substitute
        from .simulation import Simulation

        # the guards report non-finite values with step and particle; numpy's own overflow warnings would
        # only add lines to stderr
        np.seterr(all="ignore")
        sim = Simulation(log, threads=threads)
        commands = load_script(script, variables)
        for index, raw in enumerate(commands, start=1):
            where = f"{script}: command {index}"
            if not isinstance(raw, dict) or "command" not in raw:
                raise InputError(f"{where}: must be an object with a 'command' field")
            where = f"{where} ({raw.get('command')})"
            sim.execute(substitute(raw, variables, where), index, script)
        where = script
        log.info(sim.total_line())
    except (InputError, RunFailure) as exc:
        code, message = exc.exit_code, str(exc)
    except Exception as exc:  # noqa: BLE001 - the last-resort guard: one ERROR line instead of a traceback
        code, text = _unexpected(exc)
        message = f"{where}: {text}"
    finally:
        if sim is not None:
            sim.close()
            try:
                from .writers import write_timing  # as the imports of run(): after the log

                write_timing("timing.json", sim.timing_record())
            except RunFailure as exc:
                if message is None:  # the first failure is the one to report
                    code, message = exc.exit_code, str(exc)
            except Exception as exc:  # noqa: BLE001
                if message is None:
                    code, text = _unexpected(exc)
                    message = f"{script}: {text}"
        if log is not None and message is None:
            try:
                from . import cache_limit  # as the imports of run(): after the log

                cache_limit.after_run(cache_limit.cache_dir())
            except OSError as exc:  # the run's results stand; the cache stays as it is
                log.info(f"warning: the compiled-code cache was not pruned: {exc}")
        if message is not None:
            line = f"ERROR: {message}"
            if log is not None and log.handle is not None:
                try:
                    log.info(line)
                except RunFailure:
                    pass  # the log broke at its last line (echoed already); stderr still gets it
            elif echo:
                try:
                    print(line, flush=True)  # stdout shows what the log would have ended with
                except (OSError, ValueError):
                    pass
            stderr_line(line)
        if log is not None:
            log.close()
    return code


def cache_command(argv) -> int:
    """`dem -cache` and `dem -cache-prune SIZE` (engine/cache_limit.py); the exit code."""
    # the cache's module only: no numba (the jit module imports it) for a look at a folder
    from .cache_limit import KEEP_RECENT, TARGET, cache_dir, parse_size, prune, summary

    folder = cache_dir()
    try:
        if argv == ["-cache"]:
            print(summary(folder))
            return 0
        if len(argv) == 2 and argv[0] == "-cache-prune":
            try:
                size = parse_size(argv[1])
            except ValueError as exc:
                raise InputError(f"-cache-prune: {exc}") from None
            removed, freed, left = prune(folder, size) if folder.is_dir() else (0, 0, 0)
            print(f"removed {removed} entries ({freed / 2**20:.1f} MiB) from {folder}; {left / 2**20:.1f} MiB left "
                  f"(pruned to {TARGET:.0%} of {size / 2**20:.0f} MiB; entries used in the last "
                  f"{KEEP_RECENT / 3600:.0f} h are kept)")
            return 0
        raise InputError(f"bad command line ({USAGE})")
    except InputError as exc:
        stderr_line(f"ERROR: {exc}")
        return 2
    except OSError as exc:
        stderr_line(f"ERROR: {folder}: {exc.strerror or exc}")
        return 1


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] in ("-cache", "-cache-prune"):
        return cache_command(argv)
    try:
        parsed = parse_args(argv)
    except ValueError as exc:
        stderr_line(f"ERROR: {exc}")
        return 2
    if parsed is None:
        print(HELP, end="")
        return 0
    return run(*parsed)


if __name__ == "__main__":
    sys.exit(main())
