"""Run a YADE script in batch mode without YADE's TCP servers: the harness' command for the ``yade`` adapter.

    python3 launch.py --log log.yade [--refuse MESSAGE] YADE_EXECUTABLE SCRIPT.py [ARG ...]

``yade -n -x script.py`` would start, before the script, a Python prompt server on localhost:9000 and an
XML-RPC info server on port 21000 (or the next free ports; yade/remote.py, ``runServers``), listening on every
interface. Parallel harness runs need neither, so this launcher loads the YADE launcher (Debian:
``/usr/bin/yade``, a Python file) as a module, the way YADE documents for using it from other Python
programs ("yadeimport"): as a module it parses the same options (here ``-n -x``), sets OMP_NUM_THREADS (1),
loads the plug-ins and stops before the servers and the IPython session, which only run
when the launcher is ``__main__``. The script then runs in ``__main__`` with the names a YADE script expects
(``O``, ``utils``, engine classes, ...) and ``sys.argv = [SCRIPT, ARG, ...]``.

The log (``--log``) gets a header (YADE version, script, arguments, threads), everything the script prints
from Python, and ``ERROR: ...`` when the script raises (the traceback goes to stderr); the exit code is 1
then, the script's own ``sys.exit`` code otherwise. A script that ends without error and wrote no
``thermo.csv`` (one that does not use the yade_series helper, e.g. YADE's examples) gets one thermo row of
its final state (``yade_series.write_final_state``). A simulation the script left running in the background
is paused first, as ``yade -x`` ends it. ``--refuse MESSAGE`` writes ``ERROR: MESSAGE`` and exits
1 without starting YADE (a run configuration the adapter cannot run, e.g. an mpi run).

This file and yade_series.py sit alone in their folder, which Python puts first on ``sys.path`` when it runs
this file: a script finds the helper with ``import yade_series``.
"""
import importlib.machinery
import importlib.util
import os
import sys
import time
import traceback


class Tee:
    """A text stream that writes to the original stream and to the log."""

    def __init__(self, stream, log):
        self.stream, self.log = stream, log

    def write(self, text):
        self.log.write(text)
        return self.stream.write(text)

    def flush(self):
        self.log.flush()
        self.stream.flush()

    def __getattr__(self, name):
        return getattr(self.stream, name)


def _error_line(exc: BaseException, script: str) -> str:
    """``ERROR: Type: message (script.py line N)`` for the innermost frame of the script."""
    line = None
    for frame in traceback.extract_tb(exc.__traceback__):
        if os.path.basename(frame.filename) == os.path.basename(script):
            line = frame.lineno
    where = f" ({os.path.basename(script)} line {line})" if line else ""
    message = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return f"ERROR: {type(exc).__name__}: {message}{where}"


def main(argv):
    log_name, refuse = "log.yade", None
    while argv and argv[0] in ("--log", "--refuse"):
        if len(argv) < 2:
            sys.exit(f"launch.py: {argv[0]} needs a value")
        if argv[0] == "--log":
            log_name = argv[1]
        else:
            refuse = argv[1]
        argv = argv[2:]
    if len(argv) < 2:
        sys.exit("usage: launch.py [--log FILE] [--refuse MESSAGE] YADE_EXECUTABLE SCRIPT.py [ARG ...]")
    executable, script, args = argv[0], argv[1], argv[2:]
    log = open(log_name, "w", encoding="utf-8")
    if refuse:
        log.write(f"ERROR: {refuse}\n")
        log.close()
        sys.stderr.write(f"ERROR: {refuse}\n")
        return 1
    sys.stdout, sys.stderr = Tee(sys.stdout, log), Tee(sys.stderr, log)

    sys.argv = [executable, "-n", "-x", script, *args]
    loader = importlib.machinery.SourceFileLoader("yadeimport", executable)
    spec = importlib.util.spec_from_loader("yadeimport", loader)
    launcher = importlib.util.module_from_spec(spec)
    sys.modules["yadeimport"] = launcher
    start = time.perf_counter()
    loader.exec_module(launcher)
    print(f"YADE {getattr(launcher, 'version', '?')} ({executable}), script {script}, arguments {args}, "
          f"OpenMP threads {os.environ.get('OMP_NUM_THREADS', '?')}, start-up {time.perf_counter() - start:.2f} s")

    # YADE's modules exist only inside a YADE process (and the script's own __main__)
    import __main__

    namespace = __main__.__dict__
    for name, value in vars(launcher).items():
        if not name.startswith("__"):
            namespace.setdefault(name, value)
    namespace["__file__"] = os.path.abspath(script)
    code = 0
    try:
        with open(script, encoding="utf-8") as handle:
            source = handle.read()
        exec(compile(source, script, "exec"), namespace)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        if exc.code is not None and not isinstance(exc.code, int):
            print(f"ERROR: {exc.code}", file=sys.stderr)
    except BaseException as exc:  # noqa: BLE001 - whatever the script raises fails the run, with its line
        traceback.print_exc()
        print(_error_line(exc, script), file=sys.stderr)
        code = 1
    if launcher.O.running:
        # 'yade -x' ends a simulation the script left running in the background (O.run() without wait) when the
        # script ends; pausing it first lets the process exit cleanly instead of on a signal
        launcher.O.pause()
        print(f"simulation left running by the script paused at iteration {launcher.O.iter}")
    if code == 0 and not os.path.exists("thermo.csv"):
        # a script without the yade_series helper (YADE's own examples): its final state, one row
        import yade_series

        yade_series.write_final_state("thermo.csv")
        print("no thermo.csv from the script: wrote its final state (one row, source final_state)")
    print(f"exit code {code}")
    sys.stdout.flush()
    sys.stderr.flush()
    sys.stdout, sys.stderr = sys.stdout.stream, sys.stderr.stream
    log.close()
    sys.stdout.flush()
    sys.stderr.flush()
    # Leave without running destructors: YADE's plug-ins may crash while the interpreter shuts down (its own
    # exitNoBacktrace then reports "Yade: normal exit." and ends on SIGTERM, e.g. after a background run or a
    # matplotlib figure). Everything the harness reads was written and closed above.
    os._exit(code)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
