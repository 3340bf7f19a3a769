"""``harness run``: plan the runs of targets, execute them in parallel, record them in the store.

Runs execute in a local thread pool (each run is an engine subprocess) or on an existing Dask distributed
scheduler (``--scheduler ADDRESS``; the run folders must then be on a file system the workers share). The
store is written only here, in the main thread, as runs finish. A run is marked in flight (not executed,
with a start time) before it is submitted; Ctrl-C or SIGTERM kills the engines and records the runs in
flight as failed with reason ``interrupted``; the next ``harness run`` picks them up again.
"""
from __future__ import annotations

import hashlib
import os
import signal
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor
from concurrent.futures import wait as wait_futures
import dataclasses
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import NamedTuple

from filelock import Timeout

from harness.adapters import get_adapter
from harness.adapters.base import UserError
from harness.analysis.coverage import record_build_failure, record_selection, selected
from harness.config.record import STATE_LABELS
from harness.config.targets import TargetDefinition
from harness.config.testcases import RunEntry, TestCaseSpec, discover
from harness.execution import execute as ex
from harness.execution import profiles
from harness.execution.expected import expected_times
from harness.execution.builds import DONE_MARKER, BuildError, build_target, failed_build, record_current_build
from harness.execution.planning import build_info, make_spec
from harness.execution.workspace import workspace
from harness.report.textout import fit_line, wrap
from harness.report.textout import format_table  # noqa: F401  (the commands import it from here)
from harness.store.records import store_record
from harness.store.rules import SUCCESS_STATES, effective_state
from harness.store.runrecord import RunRecord, RunSpec


@dataclass
class RunOptions:
    machine: str
    pattern: str | None = None
    jobs: int = 1
    rerun_failed: bool = False
    rerun_all: bool = False
    working_tree: bool = False
    scheduler: str | None = None
    force_build: bool = False
    #: executions of each run whose stepping times are kept (``harness run --repeat N``)
    repeat: int = 1
    profile: bool = False              # record a profile of every run (harness.execution.profiles)


class Outcome(NamedTuple):
    """What a finished run tells the runs that depend on it."""

    state: str
    failure_reason: str
    folder: str


@dataclass
class Task:
    key: tuple[str, str, str, str]     # (target, test case path, run name, build commit)
    spec: RunSpec
    depends_on: tuple | None = None
    dependency_folder: str | None = None
    lock: object = None                # held from submission until the record is stored
    #: when this process chose to execute the run (UTC): a record finished after it was stored by another
    #: process sharing the workspace, and the run is not executed again
    planned: datetime = field(default_factory=lambda: datetime.now(timezone.utc))
    #: the record of a run that is not executed (its configuration has problems): stored as it is
    record: RunRecord | None = None
    #: the wall time this run configuration is expected to take (s): its last run by the target on this machine,
    #: any build, else the shipped figure (harness/execution/expected.py); None: unknown
    expected: float | None = None


@dataclass
class RunReport:
    records: list[RunRecord] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    skipped: int = 0
    elapsed: float = 0.0
    #: the builds in use (``Workspace.use_lock``, shared) until the runs are stored: ``harness gc`` skips them
    in_use: list = field(default_factory=list)

    @property
    def failed(self) -> list[RunRecord]:
        return [r for r in self.records if r.failed]


def _needs_run(existing, options: RunOptions) -> bool:
    if existing is None or options.rerun_all:
        return True
    state = effective_state(existing)
    if state in ("not_executed", "outdated"):
        return True
    if state == "failed":
        return options.rerun_failed or existing.failure_reason in ("interrupted", "dependency")
    if options.repeat > 1 and len((existing.timing or {}).get("stepping_repeats") or []) < options.repeat:
        return True  # --repeat N: a run stored with fewer stepping times runs again
    return options.profile and not existing.profile  # --profile: a run recorded without one runs again


def _build_in_use(target: TargetDefinition, options: RunOptions, report: RunReport, say):
    """Build (or find) the target's build and hold its use lock: once held, ``harness gc`` leaves the build
    and its run folders alone; a build gc removed just before is built again."""

    force = options.force_build
    while True:
        build = build_target(target, options.machine, force=force, log=say)
        lock = workspace().use_lock(target.name, build.key)
        lock.acquire()
        if not build.folder or (Path(build.folder) / DONE_MARKER).is_file():
            report.in_use.append(lock)
            return build
        lock.release()  # removed between the build and the lock
        force = False


def plan_target(target: TargetDefinition, options: RunOptions, report: RunReport, say) -> list[Task]:
    """Build the target, discover its test cases and choose the runs to execute."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run


    try:
        build = _build_in_use(target, options, report, say)
    except BuildError:
        # a revision that does not build: its selected runs are in the store, failed build_failed
        failed = failed_build(target, options.machine)
        if failed is not None:
            record_build_failure(target, failed, options.machine, options.pattern, options.working_tree)
        raise
    adapter = get_adapter(target.engine)
    testcases, problems = discover(target, adapter, options.working_tree)
    # every selected run configuration is in the store before any runs: one killed before it started is
    # still there, not executed (harness.analysis.coverage)
    record_selection(target, build, options.machine, options.pattern, options.working_tree,
                     discovered=(testcases, problems))
    report.problems.extend(problems)
    info = build_info(build)
    # a run is the same run only at the same test case content: an edited scene is run again
    existing = {(r.testcase.path, r.name, r.testcase_hash): r for r in
                Run.objects.filter(machine__name=options.machine, build=build).select_related("testcase")}
    if adapter.first_run_note and not any(r.stepping_time or r.state in SUCCESS_STATES for r in existing.values()):
        # a new build sits silent for a while before its first run reports (the bundled engine: kernels)
        say(wrap(f"{target.name}@{build.commit[:10]}: first runs of this build: {adapter.first_run_note}", ""))
    tasks: dict[tuple, Task] = {}
    expected = expected_times(target.name, options.machine)

    def add(testcase: TestCaseSpec, entry: RunEntry, force: bool = False) -> None:
        key = (target.name, testcase.path, entry.name, build.commit)
        if key in tasks:
            return
        spec = make_spec(target, info, adapter, options.machine, testcase, entry)
        if options.repeat > 1:
            spec.repeat = options.repeat
        if (options.profile or entry.config.get("profile")) and not entry.problems:

            profiles.enable(spec, adapter, entry.config.get("profile"))
        previous = existing.get((testcase.path, entry.name, spec.testcase_hash))
        if entry.problems:
            report.problems.extend(entry.problems)
            record = ex.fail(ex.base_record(spec), "config", "; ".join(entry.problems))
            record.finished = ex.now_iso()
            tasks[key] = Task(key, spec, record=record)
            return
        if not (force or _needs_run(previous, options)):
            report.skipped += 1
            return
        dependency = testcase.run(entry.depends_on) if entry.depends_on else None
        task = Task(key, spec, expected=expected.get((testcase.path, entry.name)))
        if dependency is not None:
            dep_key = (target.name, testcase.path, dependency.name, build.commit)
            dep_previous = existing.get((testcase.path, dependency.name, testcase.content_hash(dependency.name)))
            if dep_key in tasks or _needs_run(dep_previous, options) or effective_state(dep_previous) not in SUCCESS_STATES:
                add(testcase, dependency, force=True)
                task.depends_on = dep_key
            else:
                task.dependency_folder = dep_previous.folder
        tasks[key] = task

    for testcase in testcases:
        for entry in testcase.runs:
            if selected(options.pattern, testcase.path, entry.name):
                add(testcase, entry)
    return list(tasks.values())


#: thread-count variables of the engines' thread pools (the bundled engine's Numba, OpenMP in LAMMPS/LIGGGHTS)
THREAD_VARIABLES = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS")


def with_thread_share(spec: RunSpec, slots: int) -> RunSpec:
    """spec whose engine runs on its share of this machine's cores when `slots` runs go at once: a run that
    starts a thread per core while another does the same oversubscribes the cores, and threads that wait for
    each other at every step then run many times slower (measured on 2 cores, the 6,000-particle hopper of
    testcases/scenes, two runs at once: 57 s of loop time each with 2 threads, 2.6 s with 1). A count set in the
    environment or by the build is kept."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    share = str(max(1, cores // max(1, slots)))
    environment = dict(spec.environment)
    for name in THREAD_VARIABLES:
        if name not in environment and name not in os.environ:
            environment[name] = share
    return dataclasses.replace(spec, environment=environment)


class _Pool:
    """A local thread pool or a Dask distributed client behind one small interface."""

    def __init__(self, jobs: int, scheduler: str | None):
        self.client = None
        if scheduler:
            try:
                # a heavy library, loaded when this runs, not at every `harness` start
                from distributed import Client
            except ImportError:
                raise UserError("--scheduler needs the 'distributed' package (pip install 'dask[distributed]')") \
                    from None
            try:
                self.client = Client(scheduler, timeout=10)
            except OSError as exc:
                raise UserError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
            self.slots = max(jobs, sum(self.client.nthreads().values()) or 1)
        else:
            self.executor = ThreadPoolExecutor(max_workers=max(1, jobs))
            self.slots = max(1, jobs)

    def submit(self, spec: RunSpec):
        if self.client is not None:
            return self.client.submit(ex.execute, spec, pure=False)
        return self.executor.submit(ex.execute, with_thread_share(spec, self.slots))

    def wait_any(self, futures):
        if self.client is not None:
            # a heavy library, loaded when this runs, not at every `harness` start
            from distributed import wait

            return wait(list(futures), return_when="FIRST_COMPLETED").done
        return wait_futures(list(futures), return_when=FIRST_COMPLETED).done

    def cancel(self, futures):
        for future in futures:
            future.cancel()

    def close(self):
        if self.client is not None:
            self.client.close()
        else:
            self.executor.shutdown(wait=True, cancel_futures=True)


def _progress(done: int, total: int, record: RunRecord, out) -> None:
    """A line as a run ends, in the CLI's width (``harness.report.textout.fit_line``: the failure message is
    cut first, then the run's name in its middle; ``harness check -v`` prints the message whole)."""
    reason = f" ({record.failure_reason}: {record.failure_message})" if record.failed else ""
    wall = f" {record.wall_time:.2f} s" if record.wall_time is not None else ""
    width = 20
    bar = "#" * (width * done // max(total, 1))
    out.write(fit_line(f"[{bar:<{width}}] {done}/{total} ", f"{record.target} {record.testcase}/{record.run}",
                       f": {STATE_LABELS.get(record.state, record.state)}", reason, wall) + "\n")
    out.flush()


def _run_lock(task: Task):
    """The cross-process lock of a run folder: one harness process at a time runs a given run."""
    if task.lock is None:
        digest = hashlib.sha1(task.spec.folder.encode()).hexdigest()[:20]
        task.lock = workspace().lock(f"run-{digest}")
    return task.lock


def _claim(task: Task, options: RunOptions, waiting: set, out) -> str:
    """Take a run's lock without waiting: ``"claimed"``, ``"busy"`` (another process runs it) or ``"done"``
    (another process finished it while this one waited, and it need not run again)."""

    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run

    try:
        _run_lock(task).acquire(timeout=0)
    except Timeout:
        if task.key not in waiting:
            waiting.add(task.key)
            out.write(fit_line("waiting for another harness process running ",
                               f"{task.key[0]} {task.key[1]}/{task.key[2]}", " ...") + "\n")
            out.flush()
        return "busy"
    # Another process may have run it since this one planned it: one that held the lock while this one
    # waited, or one that claimed, ran and released it before this process got to the task at all.
    spec = task.spec
    row = Run.objects.filter(machine__name=spec.machine, build_id=spec.build["id"], testcase__path=spec.testcase,
                             name=spec.run, testcase_hash=spec.testcase_hash).first()
    if row is not None and row.finished is not None:
        again = RunOptions(**{**options.__dict__, "rerun_all": False})
        if row.finished >= task.planned or (task.key in waiting and not _needs_run(row, again)):
            task.lock.release()
            return "done"
    return "claimed"


def _release(task: Task) -> None:
    if task.lock is not None and task.lock.is_locked:
        task.lock.release()


def pace(finished: list[tuple[float, float]]) -> float:
    """How much longer than expected the runs finished so far took: sum of wall times / sum of expected times
    over (expected, wall) pairs (s); 1.0 before any. The shipped times come from another machine with the
    kernels cached (harness/execution/expected.py): on a slower machine, or while the engine compiles, every
    run takes longer by about the same factor (a main job on 2 vCPUs of a machine about half as fast: 1.58 to
    1.73 from its fourth run on, 1.68 in the end), and the time left is wrong by that factor unless scaled."""
    expected = sum(e for e, _wall in finished)
    return sum(wall for _e, wall in finished) / expected if expected > 0 else 1.0


def time_left(tasks_left: list[Task], durations: list, slots: int, factor: float = 1.0) -> float | None:
    """An estimate of the time the runs not finished yet take (s): each its expected time (``Task.expected``: its
    last wall time on this machine or the shipped one) times ``factor`` (``pace`` of the runs finished so far),
    or else the mean wall time of the runs finished so far, summed over the parallel slots, and at least the
    longest of them (a 5-minute hopper left alone is 5 minutes, not the mean of the short runs). None when some
    run has neither figure."""
    mean = sum(durations) / len(durations) if durations else None
    times = [task.expected * factor if task.expected is not None else mean for task in tasks_left]
    if not times or any(t is None for t in times):
        return None
    return max(sum(times) / max(slots, 1), max(times))


def run_order(tasks: list[Task]) -> list[Task]:
    """The order in which runs start when several go at once: so that the job does not end on one long run
    while the other slots sit idle, and runs compiling code do not queue up together.

    - A run whose expected time is known (``Task.expected``: its last wall time on this machine, else the one
      shipped with the repository, harness/execution/expected.py) goes by the longest chain of runs that starts
      with it (its own time plus that of the runs waiting for it, the longest branch), longest first.
    - Runs with no such figure go first (they may be long, and nothing is known that would put them later),
      taken in turn from each code build (adapter and commit), in their planned order within a build: on a
      first run every build's first runs compile (the bundled engine its kernels, per engine version), and
      runs of one build one after the other mostly need the same new kernels at the same time, where runs of
      different builds need different ones or none.

    Dependencies still hold (a run waits for the run it depends on, whatever its place)."""
    by_key = {task.key: task for task in tasks}
    waiting_for: dict = {}
    for task in tasks:
        if task.depends_on in by_key:
            waiting_for.setdefault(task.depends_on, []).append(task)
    chains: dict = {}

    def chain(task: Task) -> float | None:
        if task.key not in chains:
            chains[task.key] = None  # a cycle (not planned) counts as unknown
            rest = [chain(t) for t in waiting_for.get(task.key, [])]
            if task.expected is not None and None not in rest:
                chains[task.key] = task.expected + max(rest, default=0.0)
        return chains[task.key]

    builds: dict = {}
    for task in tasks:
        if chain(task) is None:
            builds.setdefault((task.spec.adapter, task.key[3]), []).append(task)
    unknown = [group[i] for i in range(max(map(len, builds.values()), default=0))
               for group in builds.values() if i < len(group)]
    known = sorted((task for task in tasks if chain(task) is not None), key=lambda task: -chain(task))
    return unknown + known


def _started(task: Task, since: float, tasks_left: list[Task], durations: list, slots: int, factor: float,
             out) -> None:
    """A line as a run starts: elapsed time and an estimate of what is left (``time_left``)."""
    elapsed = time.monotonic() - since
    estimate = time_left(tasks_left, durations, slots, factor)
    left = f", about {_duration(estimate)} left" if estimate is not None else ""
    target, testcase, run, commit = task.key
    out.write(fit_line("start ", f"{target}@{commit[:10]} {testcase}/{run}", f" ({_duration(elapsed)} elapsed{left})")
              + "\n")
    out.flush()


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def _record_key(record: RunRecord) -> tuple:
    return (record.target, record.testcase, record.run, record.build.get("commit", ""))


def execute_tasks(tasks: list[Task], options: RunOptions, report: RunReport, out=None) -> None:
    """Execute the planned runs and store each record as it comes back.

    Each run is claimed with a lock on its run folder first, so harness processes sharing a workspace never
    run the same run at once nor touch each other's folders; a run another process is running is waited
    for (and not run again when that process finished it).
    """
    _Execution(tasks, options, report, out or sys.stderr).run()


class _Execution:
    """One ``execute_tasks``: the runs pending, running and done, the pool they run in, the progress shown."""

    def __init__(self, tasks: list[Task], options: RunOptions, report: RunReport, out):
        self.tasks, self.options, self.report, self.out = tasks, options, report, out
        self.total = len(tasks)
        self.done_count = 0
        self.results: dict[tuple, Outcome] = {}
        self.waiting: set = set()
        self.durations: list[float] = []
        #: (expected, wall) seconds of the runs finished here that had an expected time and succeeded (``pace``)
        self.paced: list[tuple[float, float]] = []
        self.started = time.monotonic()
        self.planned = {task.key for task in tasks}
        self.pending: list[Task] = []
        self.running: dict = {}
        self.pool = None

    def run(self) -> None:
        for task in self.tasks:
            if task.record is not None:
                self.finish(task.record)
            else:
                self.pending.append(task)
        if not self.pending:
            return
        self.pool = _Pool(self.options.jobs, self.options.scheduler)
        if self.pool.slots > 1:
            self.pending = run_order(self.pending)
        try:
            while self.pending or self.running:
                submitted = self.submit_ready()
                if not self.running:
                    if self.pending and not submitted:
                        time.sleep(0.2)  # every remaining run is held by another process
                    continue
                self.collect()
        except KeyboardInterrupt:
            self.interrupted()
            raise
        finally:
            self.pool.close()
            ex.clear_interrupt()
            for task in self.tasks:
                _release(task)

    def finish(self, record: RunRecord, task: Task | None = None) -> None:
        """Store a run's record (releasing its claim) and show the progress."""
        try:
            store_record(record)
        finally:
            if task is not None:
                _release(task)
        self.report.records.append(record)
        self.results[_record_key(record)] = Outcome(record.state, record.failure_reason, record.folder)
        self.durations.append(record.wall_time or 0.0)
        # a run that failed early says nothing of how long the others take
        if task is not None and task.expected and record.wall_time and record.state in SUCCESS_STATES:
            self.paced.append((task.expected, record.wall_time))
        self.done_count += 1
        _progress(self.done_count, self.total, record, self.out)

    def dependency(self, task: Task) -> tuple[bool, Outcome | None]:
        """(whether ``task`` can start now, the result of the run it depends on or None)."""
        if task.depends_on is None:
            return True, None
        dep = self.results.get(task.depends_on)
        if dep is None and task.depends_on in self.planned:
            return False, None  # its dependency has not finished yet
        return True, dep if dep is not None else Outcome("not_executed", "", "")

    def submit_ready(self) -> bool:
        """Start the pending runs whose dependency is done and that no other process holds, while the pool
        has free slots; whether any pending run was taken up."""
        submitted = False
        for task in list(self.pending):
            if len(self.running) >= self.pool.slots:
                break
            ready, dep = self.dependency(task)
            if not ready:
                continue
            claim = _claim(task, self.options, self.waiting, self.out)
            if claim == "busy":
                continue
            self.pending.remove(task)
            submitted = True
            if claim == "done":
                self.done_elsewhere(task)
            elif dep is not None and dep.state not in SUCCESS_STATES:
                record = ex.fail(ex.base_record(task.spec), "dependency",
                                 f"dependency {task.depends_on[2]!r} {dep.state}"
                                 + (f" ({dep.failure_reason})" if dep.failure_reason else ""))
                record.finished = ex.now_iso()
                self.finish(record, task)
            else:
                self.submit(task, dep)
        return submitted

    def done_elsewhere(self, task: Task) -> None:
        """A run another process finished meanwhile: its stored result stands for it (not run again)."""
        # the store's models load once Django is set up (harness.store)
        from harness.store.models import Run

        row = Run.objects.get(build_id=task.spec.build["id"], machine__name=task.spec.machine,
                              testcase__path=task.spec.testcase, name=task.spec.run,
                              testcase_hash=task.spec.testcase_hash)
        self.results[task.key] = Outcome(row.state, row.failure_reason, row.folder)
        self.report.skipped += 1
        self.total -= 1

    def submit(self, task: Task, dep: Outcome | None) -> None:
        """Record the run as started and hand it to the pool (in the folder of the run it depends on)."""
        if dep is not None:
            task.spec.dependency_folder = dep.folder
        elif task.dependency_folder:
            task.spec.dependency_folder = task.dependency_folder
        in_flight = ex.base_record(task.spec)
        in_flight.started = ex.now_iso()
        store_record(in_flight)
        self.running[self.pool.submit(task.spec)] = task
        _started(task, self.started, self.pending + list(self.running.values()), self.durations, self.pool.slots,
                 pace(self.paced), self.out)

    def collect(self) -> None:
        """Wait for at least one running run and store what came back."""
        for future in self.pool.wait_any(self.running):
            task = self.running.pop(future)
            try:
                record = future.result()
            except Exception as exc:  # noqa: BLE001 - a harness bug in one run must not stop the rest
                record = ex.fail(ex.base_record(task.spec), "post_processing",
                                 f"harness error: {type(exc).__name__}: {exc}")
                record.finished = ex.now_iso()
            self.finish(record, task)

    def interrupted(self) -> None:
        """Ctrl-C: stop the engines and record the runs in flight as interrupted."""
        # a second Ctrl-C (or SIGTERM) must not cut the recording of the runs in flight short
        previous = {sig: signal.signal(sig, signal.SIG_IGN) for sig in (signal.SIGINT, signal.SIGTERM)} \
            if threading.current_thread() is threading.main_thread() else {}
        try:
            self.out.write("harness: interrupted: stopping the engines and recording the runs in flight "
                           "(further Ctrl-C is ignored until that is done)\n")
            self.out.flush()
            ex.kill_all_running()
            self.pool.cancel(self.running)
            self.pool.close()  # let the local workers see their engines die and stop before the records are written
            for task in self.running.values():
                record = ex.fail(ex.base_record(task.spec), "interrupted", "the harness was interrupted")
                record.finished = ex.now_iso()
                ex.write_record(record)
                try:
                    store_record(record)
                finally:
                    _release(task)
                self.report.records.append(record)
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)


def run_targets(targets: list[TargetDefinition], options: RunOptions, out=None) -> RunReport:
    """Build, plan and execute; problems (bad files, failed builds) are reported and the rest goes on."""
    out = out or sys.stderr
    report = RunReport()
    tasks: list[Task] = []
    say = (lambda text: (out.write(text + "\n"), out.flush()))
    started = time.perf_counter()
    try:
        for target in targets:
            try:
                tasks.extend(plan_target(target, options, report, say))
            except UserError as exc:
                report.problems.append(str(exc))
        for problem in report.problems:
            out.write(f"harness: {problem}\n")
        started = time.perf_counter()
        execute_tasks(tasks, options, report, out)
    finally:
        for lock in report.in_use:
            lock.release()
    report.elapsed = time.perf_counter() - started
    return report


def run_and_read(targets: list[TargetDefinition], options: RunOptions, run: bool = True) -> tuple[int, list]:
    """Run the selected runs of ``targets`` (unless not ``run``: only read the store), then the live runs of
    each target's current build on the machine, for the commands that tabulate studies over run points
    (``harness scaling``, ``harness sweep``). Returns (runs that failed, [(target, build, runs)]), a target
    whose revision is not built here left out."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run

    failed = len(run_targets(targets, options).failed) if run else 0
    found = []
    for target in targets:
        build = record_current_build(target, options.machine)
        if build is not None:
            found.append((target, build, Run.objects.filter(build=build, machine__name=options.machine,
                                                            replaced=False)))
    return failed, found


def cost_per_particle_step(timing: dict) -> float | None:
    """Microseconds of time stepping per particle-step (CPU time where the engine reports it), or None.

    This is the figure that shows what each effect of a scene costs (testcases/effects/).
    """
    steps = (timing or {}).get("particle_steps")
    seconds = (timing or {}).get("cpu") or (timing or {}).get("total")
    return 1e6 * seconds / steps if steps and seconds else None


def summary_table(records: list[RunRecord]) -> str:
    rows = [("target", "commit", "test case", "run", "state", "reason", "wall s", "stepping s", "us/particle-step")]
    for r in sorted(records, key=lambda r: (r.target, r.testcase, r.run)):
        cost = cost_per_particle_step(r.timing)
        rows.append((r.target, r.build.get("commit", "")[:10], r.testcase, r.run, STATE_LABELS.get(r.state, r.state),
                     r.failure_reason or "", f"{r.wall_time:.2f}" if r.wall_time is not None else "-",
                     f"{r.stepping_time:.3f}" if r.stepping_time is not None else "-",
                     f"{cost:.3f}" if cost is not None else "-"))
    # states and failure reasons are single words a reader scans for: never cut (paths and names are)
    return format_table(rows, keep=("target", "state", "reason"))

