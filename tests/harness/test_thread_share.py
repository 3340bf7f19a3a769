"""Runs that go at once share the machine's cores (harness.execution.scheduler.with_thread_share)."""
import os

from harness.execution.scheduler import THREAD_VARIABLES, with_thread_share
from harness.store.runrecord import RunSpec


def spec_with(environment: dict) -> RunSpec:
    return RunSpec(machine="m", target="t", target_definition={}, build={}, testcase="c", run="r", testcase_hash="",
                   config={}, adapter="dem", thermo_columns={}, environment=environment, workspace="/w", folder="/w/r",
                   source_folder="/c", files=[])


def test_each_of_several_runs_gets_its_share_of_the_cores(monkeypatch):
    for name in THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1, 2, 3})
    spec = spec_with({"PYTHONPATH": "/x"})
    assert with_thread_share(spec, 2).environment == {"PYTHONPATH": "/x", "NUMBA_NUM_THREADS": "2",
                                                          "OMP_NUM_THREADS": "2"}
    assert with_thread_share(spec, 8).environment["NUMBA_NUM_THREADS"] == "1"
    assert with_thread_share(spec, 1).environment["OMP_NUM_THREADS"] == "4"
    assert spec.environment == {"PYTHONPATH": "/x"}  # not changed in place


def test_a_thread_count_the_user_or_the_build_set_is_kept(monkeypatch):
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    out = with_thread_share(spec_with({"NUMBA_NUM_THREADS": "5"}), 2).environment
    assert out == {"NUMBA_NUM_THREADS": "5"}
