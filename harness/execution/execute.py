"""Executing one run (thesis 4.3.4-4.3.5) in a fresh run folder, without touching the store.

``execute(spec)`` takes a ``RunSpec`` (picklable, so it can be shipped to a Dask worker), prepares the run folder (a
copy of the test case folder, the dependency's ``post/`` copied in), runs the engine as a subprocess in its
own session (a timeout kills the whole process tree), classifies the outcome into the run states and
failure reasons, post-processes, writes ``run.json`` and returns that record (a ``RunRecord``).
"""
from __future__ import annotations

import dataclasses
import os
import shutil
import signal
import stat
import statistics
import subprocess
import tempfile
import threading
import time
import uuid
from datetime import datetime, timezone
from pathlib import Path

from harness.adapters import get_adapter
from harness.adapters.base import LogScan, UserError
from harness.adapters.dem import scan_lines
from harness.execution import profiles
from harness.execution.postprocess import (
    frame_to_series,
    non_finite_columns,
    read_declared,
    vtk_aggregates,
)
from harness.execution.workspace import PROJECT_ROOT, Workspace
from harness.store import runrecord
from harness.store.runrecord import RunRecord, RunSpec

RECORD_FILE = runrecord.RECORD_FILE
STDOUT, STDERR, POST_LOG = "stdout.txt", "stderr.txt", "post_scripts.log"
TAIL_LINES = 60

#: process groups of runs in flight in this process: run folder -> pid (killed on interrupt)
_running: dict[str, int] = {}
_running_lock = threading.Lock()
#: set while the harness is being interrupted: runs ending now are recorded as interrupted, not as killed
_interrupted = threading.Event()


def now_iso() -> str:
    return datetime.now(timezone.utc).isoformat()


def kill_group(pid: int, grace: float = 2.0) -> None:
    """SIGTERM the process group, then SIGKILL what is left after ``grace`` s."""
    try:
        os.killpg(pid, signal.SIGTERM)
    except ProcessLookupError:
        return
    deadline = time.monotonic() + grace
    while time.monotonic() < deadline:
        try:
            os.killpg(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    try:
        os.killpg(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


#: environment variable carrying a per-process token: every process a run or post script starts inherits it,
#: also one that left the session with setsid, so what is left over can be found and killed by it (the way
#: Jenkins' process tree killer finds a build's daemons by its BUILD_ID cookie)
TOKEN_VARIABLE = "HARNESS_RUN_TOKEN"


def new_token() -> str:

    return uuid.uuid4().hex


def kill_tagged(token: str, rounds: int = 5) -> int:
    """SIGKILL every process whose environment holds ``HARNESS_RUN_TOKEN=token``; returns how many. Repeated
    a few rounds: a process may fork while the first round reads ``/proc``."""
    needle = f"{TOKEN_VARIABLE}={token}".encode()
    me, killed = os.getpid(), 0
    for _ in range(rounds):
        found = 0
        for entry in os.scandir("/proc") if os.path.isdir("/proc") else ():
            if not entry.name.isdigit() or int(entry.name) == me:
                continue
            try:
                with open(f"/proc/{entry.name}/environ", "rb") as handle:
                    environment = handle.read()
            except OSError:
                continue  # gone, or another user's
            if needle in environment.split(b"\0"):
                try:
                    os.kill(int(entry.name), signal.SIGKILL)
                    found += 1
                except (ProcessLookupError, PermissionError):
                    pass
        killed += found
        if not found:
            break
        time.sleep(0.02)
    return killed


def kill_all_running() -> list[str]:
    """Kill every engine process group started by this process; returns their run folders.

    Runs whose engine dies this way record themselves as interrupted until ``clear_interrupt()``.
    """
    _interrupted.set()
    with _running_lock:
        items = list(_running.items())
    for _folder, pid in items:
        kill_group(pid, grace=0.5)
    return [folder for folder, _pid in items]


def clear_interrupt() -> None:
    _interrupted.clear()


def tail(path: Path, lines: int = TAIL_LINES) -> str:
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return ""
    return "\n".join(text.splitlines()[-lines:])


def signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def prepare_folder(spec: RunSpec) -> Path:
    """A fresh run folder holding the test case's files (``harness.config.testcases.testcase_files``, the files its
    content hash covers) and the dependency's ``post/``. Only a folder inside the workspace is replaced."""
    folder = Path(spec.folder)
    Workspace.at(spec.workspace).fresh_folder(folder)
    source_folder = Path(spec.source_folder)
    for rel in spec.files:
        source, destination = source_folder / rel, folder / rel
        destination.parent.mkdir(parents=True, exist_ok=True)
        if source.is_symlink():
            os.symlink(os.readlink(source), destination)
        else:
            shutil.copy2(source, destination)
    (folder / "post").mkdir(exist_ok=True)
    dependency = spec.dependency_folder
    if dependency:
        source = Path(dependency) / "post"
        if source.is_dir():
            shutil.copytree(source, folder / "post", dirs_exist_ok=True, symlinks=True)
    return folder


def base_record(spec: RunSpec) -> RunRecord:
    """A fresh record of the run ``spec`` describes."""
    return spec.record()


def write_record(record: RunRecord) -> None:
    folder = Path(record.folder)
    if folder.is_dir():
        tmp = folder / (RECORD_FILE + ".tmp")
        tmp.write_text(runrecord.dumps(record))
        os.replace(tmp, folder / RECORD_FILE)


def fail(record: RunRecord, reason: str, message: str) -> RunRecord:
    return record.fail(reason, message)


def _run_engine(spec: RunSpec, folder: Path, record: RunRecord) -> tuple[int | None, bool]:
    """Run the command; returns (exit code, timed out)."""
    ws = Workspace.at(spec.workspace)
    (ws.home / "tmp").mkdir(parents=True, exist_ok=True)
    session = Path(tempfile.mkdtemp(prefix="mpi-", dir=ws.home / "tmp"))
    try:
        return _run_engine_in(spec, folder, session)
    finally:
        ws.remove_tree(session)


def _run_engine_in(spec: RunSpec, folder: Path, session: Path) -> tuple[int | None, bool]:
    env = dict(os.environ)
    env.update(spec.environment)
    # Open MPI (LIGGGHTS, LAMMPS, mpirun) keeps a session folder per user in /tmp; engines starting at the same
    # moment race to create it ("mkdir ... File exists") and one dies: each run gets its own
    env["OMPI_MCA_orte_tmpdir_base"] = str(session)
    env[TOKEN_VARIABLE] = token = new_token()
    timeout = spec.timeout
    with open(folder / STDOUT, "wb") as out, open(folder / STDERR, "wb") as err:
        try:
            process = subprocess.Popen(spec.command, cwd=folder, env=env, stdout=out, stderr=err,
                                       stdin=subprocess.DEVNULL, start_new_session=True)
        except OSError as exc:
            err.write(f"cannot start {spec.command[0]}: {exc.strerror}\n".encode())
            return 127, False
        with _running_lock:
            _running[str(folder)] = process.pid
        try:
            try:
                return process.wait(timeout=timeout), False
            except subprocess.TimeoutExpired:
                kill_group(process.pid)
                process.wait()
                return process.returncode, True
        finally:
            # the engine may have left children behind (mpirun's ranks): they go with the group, and
            # whatever left the group (setsid) with the token
            try:
                os.killpg(process.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            kill_tagged(token)
            with _running_lock:
                _running.pop(str(folder), None)


def _run_post_scripts(spec: RunSpec, folder: Path, record: RunRecord) -> bool:
    """Run the post scripts in order in the run folder (thesis 4.3.5); False if one failed.

    Each runs in its own session like the engine; when it ends - normally or by its timeout - its whole
    process group is killed, so background children it started (``sleep 1000 &``) never outlive it, and
    a child still holding its output cannot keep the harness waiting.
    """
    env = dict(os.environ)
    env.update(spec.environment)
    # post scripts may use the harness' own readers (harness.execution.postprocess ...) whatever the build's environment
    # puts on PYTHONPATH (the bundled engine's build sets it to its exported source)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (env.get("PYTHONPATH"), str(PROJECT_ROOT)) if p)
    timeout = spec.timeout
    with open(folder / POST_LOG, "ab") as log:
        for script in spec.config.get("post_scripts", []):
            path = folder / script
            if not path.is_file():
                fail(record, "post_script", f"post script {script!r} not found")
                return False
            with open(path, "rb") as handle:
                if handle.read(2) != b"#!":
                    fail(record, "post_script", f"post script {script!r} has no shebang (#!) line")
                    return False
            # git archive and copies keep the mode; a script checked in without +x still has a shebang
            path.chmod(path.stat().st_mode | stat.S_IXUSR)
            log.write(f"$ {script}\n".encode())
            log.flush()
            code, timed_out, stderr = _run_post_script(path, folder, env, log, timeout)
            if code is None:
                fail(record, "post_script", f"post script {script!r} cannot start: {stderr}")
                return False
            log.write(stderr)
            if _interrupted.is_set():
                fail(record, "interrupted", "the harness was interrupted")
                return False
            if timed_out:
                fail(record, "post_script", f"post script {script!r} timed out after {timeout:g} s "
                     "(process group killed)")
                return False
            if code != 0:
                last = stderr.decode("utf-8", "replace").strip().splitlines()[-1:] or [""]
                how = f"was killed by {signal_name(-code)}" if code < 0 else f"exited with code {code}"
                fail(record, "post_script", f"post script {script!r} {how}: {last[0]}".rstrip(": "))
                return False
    return True


def _run_post_script(path: Path, folder: Path, env: RunSpec, log, timeout: float) -> tuple[int | None, bool, bytes]:
    """(exit code or None when it cannot start, timed out, stderr). stderr goes to an unnamed file, not a
    pipe: a pipe stays open as long as any child holds it, a file is read once the script ended."""
    env = {**env, TOKEN_VARIABLE: (token := new_token())}
    with tempfile.TemporaryFile() as err:
        began = time.monotonic()
        try:
            process = subprocess.Popen([str(path.resolve())], cwd=folder, env=env, stdout=log, stderr=err,
                                       stdin=subprocess.DEVNULL, start_new_session=True)
        except OSError as exc:
            return None, False, (exc.strerror or str(exc)).encode()
        key = f"{folder}#post"
        with _running_lock:
            _running[key] = process.pid  # Ctrl-C kills it with the engines (kill_all_running)
        try:
            try:
                code, timed_out = process.wait(timeout=timeout), False
            except subprocess.TimeoutExpired:
                kill_group(process.pid)
                code, timed_out = process.wait(), True
            timed_out = timed_out or time.monotonic() - began > timeout
        finally:
            try:  # what the script left running in its group goes with it
                os.killpg(process.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            kill_tagged(token)  # and what it started in a session of its own (setsid, daemons)
            with _running_lock:
                _running.pop(key, None)
        err.seek(0)
        return code, timed_out, err.read()


def _classify(record: RunSpec, code: int | None, timed_out: bool, scan, timeout: float) -> None:
    errors = scan.errors
    detail = f": {errors[-1]}" if errors else ""
    if timed_out:
        fail(record, "timeout", f"timed out after {timeout:g} s (process tree killed)")
    elif code is not None and code < 0:
        fail(record, "signal", f"killed by {signal_name(-code)}{detail}")
    elif code:
        if not detail and record.stderr_tail.strip():
            detail = ": " + record.stderr_tail.strip().splitlines()[-1][:300]
        fail(record, "exit_code", f"exit code {code}{detail}")
    elif errors:
        fail(record, "error_line", f"exit code 0 but the log has an error: {errors[0]}")


def execute(spec: RunSpec) -> RunRecord:
    """Run one run configuration; returns the run record (also written to ``run.json``)."""
    record = base_record(spec)
    adapter = get_adapter(spec.adapter)
    try:
        folder = prepare_folder(spec)
    except (OSError, UserError) as exc:
        # a full disk, a file where a folder belongs, a folder the workspace refuses to replace: this run
        # fails (reason config: its folder is part of its configuration), the others go on
        detail = f"{exc.strerror} ({exc.filename})" if isinstance(exc, OSError) and exc.strerror else str(exc)
        record.finished = now_iso()
        return fail(record, "config", f"cannot prepare run folder {spec.folder}: {detail}")
    record.started = now_iso()
    # what the run configuration declares to the engine itself (a relaxed blow-up limit: the adapter knows how)
    declared = adapter.run_environment(spec.config)
    if declared:
        spec = dataclasses.replace(spec, environment={**spec.environment, **declared})
    start = time.perf_counter()
    code, timed_out = _run_engine(spec, folder, record)
    record.wall_time = time.perf_counter() - start
    record.finished = now_iso()
    record.exit_code = code
    # a run that outlived its timeout failed, however short the timeout: the process may have ended between
    # the moment the wait gave up and the moment it was killed, or before the first poll of a tiny timeout
    timed_out = timed_out or record.wall_time > spec.timeout
    if _interrupted.is_set():
        fail(record, "interrupted", "the harness was interrupted")
        write_record(record)
        return record
    record.stderr_tail = tail(folder / STDERR, 20)
    record.log_tail = tail(folder / adapter.log_file()) or tail(folder / STDOUT)

    missing = None
    try:
        scan = adapter.scan_log(folder)
        record.timing = adapter.read_timing(folder)
    except UserError as exc:  # no log at all: the engine did not start, or died first
        scan, missing = LogScan(), str(exc)
    stderr_scan = scan_lines(record.stderr_tail)
    scan.errors += [line for line in stderr_scan.errors if line not in scan.errors]
    record.warning_count = len(scan.warnings)
    record.warnings = scan.warnings[:50]
    record.stepping_time = runrecord.stepping_time_of(record.timing)
    try:
        record.breakdown = adapter.read_breakdown(folder, record.timing)
    except UserError:
        record.breakdown = {}
    if spec.profile:

        profiles.finish(spec, folder, record)
    _classify(record, code, timed_out, scan, spec.timeout)
    if spec.repeat > 1 and record.state != "failed" and record.stepping_time:
        _repeat(spec, folder, record, adapter)
    if missing and record.state != "failed":
        fail(record, "missing_output", missing)
    try:
        postprocess_run(spec, folder, record, adapter)
    except Exception as exc:  # noqa: BLE001 - a post-processing bug must not lose the run
        if record.state != "failed":
            fail(record, "post_processing", f"{type(exc).__name__}: {exc}")
    write_record(record)
    return record


def _repeat(spec: RunSpec, folder: Path, record: RunSpec, adapter) -> None:
    """``harness run --repeat N``: run the engine N - 1 more times in the run folder (the engine's results
    are the same bytes each time) and keep every stepping time in ``timing["stepping_repeats"]`` (s, in
    order); the run's stepping time becomes their median. A repeat that fails or times out ends the
    series (the first run's outcome stands)."""

    times = [record.stepping_time]
    for _ in range(spec.repeat - 1):
        code, timed_out = _run_engine(spec, folder, record)
        if code != 0 or timed_out or _interrupted.is_set():
            break
        try:
            again = runrecord.stepping_time_of(adapter.read_timing(folder))
        except UserError:
            break
        if again:
            times.append(again)
    record.timing = {**record.timing, "stepping_repeats": times}
    record.stepping_time = statistics.median(times)


def postprocess_run(spec: RunSpec, folder: Path, record: RunSpec, adapter) -> None:
    """Thermo (kept even for failed runs), then for successful runs post scripts, data, VTK, acceptance."""

    config = spec.config
    mapping = spec.thermo_columns or None
    thermo = None
    try:
        thermo = adapter.read_thermo(folder, mapping)
    except UserError as exc:
        if record.state != "failed":
            fail(record, "missing_output", str(exc))
    if thermo is not None:
        record.series.append(frame_to_series("thermo", "thermo", thermo, "step"))
        bad = non_finite_columns(thermo)
        if bad and record.state != "failed":
            fail(record, "non_finite", f"non-finite values in thermo column(s) {', '.join(bad)}")
    if record.state == "failed":
        return
    record.state = "executed"
    if not _run_post_scripts(spec, folder, record):
        return
    try:
        frames, stored = read_declared(folder, config.get("data") or {})
        files = adapter.vtk_files(folder)
        if files:
            density = (config.get("vtk") or {}).get("density")
            dumps = vtk_aggregates(files, density)
            record.series.append(frame_to_series("vtk", "dumps", dumps, "step",
                                                    {"files": [str(p.relative_to(folder)) for p in files],
                                                     "units": dumps.attrs.get("units", {})}))
    except UserError as exc:
        fail(record, "post_processing", str(exc))
        return
    record.series.extend(stored)
    frames["thermo"] = thermo
    overlaps = adapter.largest_overlaps(folder)
    if overlaps:  # the engine's own report, for the default blow-up check (harness.config.acceptance)
        # a heavy library, loaded when this runs, not at every `harness` start
        import pandas as pd

        frames.setdefault("engine_log", pd.DataFrame({"block": range(1, len(overlaps) + 1),
                                                      "max_overlap": overlaps}))
    try:
        # optional: a trimmed install without the acceptance checks still runs and records its runs
        from harness.config import acceptance
    except ImportError:
        acceptance = None
    if acceptance is not None:  # the default stability checks apply to every run (harness.config.acceptance)
        verdicts = acceptance.evaluate(config, frames, folder, engine=adapter.name)
        record.verdicts = [{"ok": bool(v.ok), "reason": v.reason, "message": v.message} for v in verdicts]
        bad = [v for v in verdicts if not v.ok]
        if bad:
            reason = bad[0].reason if bad[0].reason in ("expectation", "stability") else "expectation"
            fail(record, reason, "; ".join(v.message for v in bad))
            return
    record.state = "post_processed"
