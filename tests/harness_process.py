"""How the tests start the harness and the DEM codes as programs, and read what they leave behind - one copy for
every test folder (``pythonpath = ["tests"]`` in pyproject.toml puts this folder on the import path).

- ``harness``: ``python -m harness.cli --machine M --home HOME [--targets DIR] ARGS`` from the project folder;
- ``records`` / ``series``: the run.json records of a target's runs and a series' columns in one;
- ``run_code``: one run of a code in a folder with its adapter's command line (as ``harness run`` starts it);
- ``git_repo`` / ``commit_files``: temporary git repositories for targets;
- ``free_port`` / ``stop_session``: a port for a test's server, and stopping the server's process group;
- ``as_from_a_terminal``: Ctrl-C reaches a started program as it would from a terminal.
"""
from __future__ import annotations

import contextlib
import json
import os
import random
import signal
import socket
import subprocess
import sys
from pathlib import Path

import git

PROJECT = Path(__file__).resolve().parents[1]
#: the machine name the tests' harness processes record their runs under
MACHINE = "testbox"


def command(home: Path, *args: str, targets: Path | None = None, machine: str = MACHINE) -> list[str]:
    """The command line of ``harness ARGS`` on the store under ``home``, recording as ``machine``."""
    line = [sys.executable, "-m", "harness.cli", "--machine", machine, "--home", str(home)]
    if targets is not None:
        line += ["--targets", str(targets)]
    return line + [str(a) for a in args]


def as_from_a_terminal() -> None:
    """``preexec_fn`` of a program a test interrupts with SIGINT: the signal's default action, whatever this
    process inherited. A shell without job control starts a background command (``bash .ci/run &``) with SIGINT
    ignored, every program it starts inherits that, and Python then installs no KeyboardInterrupt handler: the
    harness would never see the Ctrl-C the test sends."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def harness(home: Path, *args: str, targets: Path | None = None, check: bool = True, machine: str = MACHINE,
            timeout: float = 600, env: dict | None = None, popen: bool = False):
    """Run ``harness ARGS`` on the store under ``home``; with ``check`` its exit code must be 0 (the output is
    in the assertion). ``env``: the whole environment (None: this process'); ``popen``: start it and return
    the Popen (stdout and stderr piped, Ctrl-C as from a terminal) instead of waiting."""
    line = command(home, *args, targets=targets, machine=machine)
    if popen:
        return subprocess.Popen(line, cwd=PROJECT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, preexec_fn=as_from_a_terminal)
    result = subprocess.run(line, cwd=PROJECT, capture_output=True, text=True, errors="replace",
                            timeout=timeout, env=env)
    if check:
        assert result.returncode == 0, result.stdout + result.stderr
    return result


def project_env(**extra: str) -> dict:
    """This process' environment with the project first on PYTHONPATH, no HARNESS_HOME (``--home`` names the
    store) and no DJANGO_SETTINGS_MODULE (the harness picks its store settings), plus ``extra``."""
    environment = {**os.environ, "PYTHONPATH": str(PROJECT), **extra}
    environment.pop("HARNESS_HOME", None)
    environment.pop("DJANGO_SETTINGS_MODULE", None)
    return environment


def records(home: Path, target: str, machine: str = MACHINE) -> dict[str, dict]:
    """The newest run.json record per 'test case/run' of a target's runs."""
    found = {}
    for path in sorted((home / "runs" / machine / target).rglob("run.json"), key=lambda p: p.stat().st_mtime):
        record = json.loads(path.read_text())
        found[f"{record['testcase']}/{record['run']}"] = record
    return found


def series(record: dict, kind: str) -> dict:
    """The columns of a run record's series of ``kind`` (thermo, vtk, plot, textfile)."""
    return next(s for s in record["series"] if s["kind"] == kind)["columns"]


def run_code(adapter, executable: list[str], folder: Path, script: str, variables: dict | None = None,
             nprocs: int = 1, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run a code in ``folder`` with ``adapter``'s command line, on ``nprocs`` MPI ranks with the launcher
    prefix ``harness run`` uses (``harness.adapters.base.with_open_mpi_flags``); stdout and stderr land in
    the folder as ``stdout.txt`` and ``stderr.txt``, as the harness keeps them."""
    from harness.adapters.base import with_open_mpi_flags

    mpi = with_open_mpi_flags(["mpirun", "-np", str(nprocs)]) if nprocs > 1 else None
    command = adapter.command(list(executable), script, variables or {}, adapter.log_file(), mpi)
    (folder / "post").mkdir(exist_ok=True)
    # errors="replace": after an ERROR, LIGGGHTS 3.8 sometimes prints a line of stray bytes on the screen
    result = subprocess.run(command, cwd=folder, capture_output=True, text=True, errors="replace", timeout=timeout)
    (folder / "stdout.txt").write_text(result.stdout)
    (folder / "stderr.txt").write_text(result.stderr)
    return result


def git_repo(folder: Path):
    """A new git repository in ``folder`` with a committer set."""
    folder.mkdir(parents=True, exist_ok=True)
    repo = git.Repo.init(folder)
    with repo.config_writer() as config:
        config.set_value("user", "name", "Test")
        config.set_value("user", "email", "test@example.org")
    return repo


def commit_files(repo, files: dict, message: str, tag: str | None = None) -> str:
    """Write ``{relative path: text}`` (``None`` deletes; scripts become executable) and commit; returns the
    commit id."""
    root = Path(repo.working_tree_dir)
    for rel, text in files.items():
        path = root / rel
        if text is None:
            path.unlink()
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        if rel.startswith("scripts/") or rel.endswith(".sh") or "/scripts/" in rel:
            path.chmod(0o755)
    repo.git.add("-A")
    repo.index.commit(message)
    if tag:
        repo.create_tag(tag)
    return repo.head.commit.hexsha


def free_port() -> int:
    """A free TCP port on 127.0.0.1 below the kernel's ephemeral range.

    A port the kernel hands out (binding port 0) is in the ephemeral range, which every outgoing connection on the
    machine also draws its source port from: between this check and the server's bind, another connection - even
    the test's own polling of the port - can take it, and the server then fails with "Address already in use".
    Below the range only an explicit bind can take the port.
    """
    low = 32768
    with contextlib.suppress(OSError, ValueError):
        low = int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    for _ in range(200):
        port = random.randrange(10000, max(low, 10001))
        with socket.socket() as probe:
            try:
                probe.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    raise RuntimeError(f"no free port between 10000 and {low}")


def stop_session(process: subprocess.Popen, timeout: float = 30) -> None:
    """Stop a server started with ``start_new_session=True`` and its children (it may have exited already)."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGTERM)
    try:
        process.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=timeout)
