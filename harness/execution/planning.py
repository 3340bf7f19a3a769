"""The run spec of one run configuration: everything a worker needs to execute it
(``harness.store.runrecord.RunSpec``, picklable, so Dask workers get it) - its command line with the MPI
launcher prefix, its run folder, its environment and the build it runs. ``harness run`` plans with it
(``harness.execution.scheduler``); ``harness.analysis.coverage`` records the run configurations not executed
with it.
"""
from __future__ import annotations

import json
import shlex
from pathlib import Path

from harness.adapters.base import with_open_mpi_flags
from harness.analysis import scaling
from harness.config.targets import TargetDefinition
from harness.config.testcases import RunEntry, TestCaseSpec
from harness.execution.workspace import workspace
from harness.store.runrecord import RunSpec


def mpi_prefix(target: TargetDefinition, config: dict) -> list[str] | None:
    """Launcher prefix for mpi runs (thesis listing 4.3: ``mpirun -np 4``), None for serial runs.

    Open MPI refuses to start as root and to place more ranks than cores; in a container (root, few cores)
    ``--allow-run-as-root`` and ``--oversubscribe`` are added, and only then
    (``harness.adapters.base.with_open_mpi_flags``).
    """
    run_type = config.get("type", "serial")
    if run_type == "serial":
        return None
    launcher = list(target.mpi_launcher)
    if run_type == "mpi/custom":
        options = config.get("mpi_options", [])
        return with_open_mpi_flags(
            launcher + (shlex.split(options) if isinstance(options, str) else [str(o) for o in options]))
    return with_open_mpi_flags(launcher + ["-np", str(int(config["nprocs"]))])


def run_folder(machine: str, target: str, build_key: str, testcase: str, run: str, testcase_hash: str) -> Path:
    """``runs/<machine>/<target>/<commit>-<definition>/<test case>/<run>.<content hash>/``: a folder per
    build and test case content, so no later run overwrites an earlier revision's files."""
    return workspace().runs / machine / target / build_key / testcase / f"{run}.{testcase_hash[:8]}"


def build_info(build) -> dict:
    """What a run spec records of the build it runs (``make_spec``), from the store's row."""
    return {"id": build.id, "key": build.key, "commit": build.commit, "revision": build.revision,
            "definition_hash": build.definition_hash, "executable": json.loads(build.executable or "[]"),
            "environment": build.environment or {}, "folder": build.folder,
            "committed_at": build.committed_at.isoformat() if build.committed_at else None,
            "commit_message": build.commit_message}


def make_spec(target: TargetDefinition, build_info: dict, adapter, machine: str, testcase: TestCaseSpec,
              entry: RunEntry) -> RunSpec:
    config = entry.config
    mapping = dict(target.thermo_columns)
    mapping.update(config.get("thermo_columns") or {})
    variables = {str(k): v for k, v in (config.get("variables") or {}).items()}
    content = testcase.content_hash(entry.name)
    spec = RunSpec(
        machine=machine, target=target.name, target_definition=target.as_dict(), build=build_info,
        testcase=testcase.path, run=entry.name, testcase_hash=content, config=config, adapter=adapter.name,
        thermo_columns=mapping, environment={**build_info["environment"], **scaling.thread_environment(config)},
        workspace=str(workspace().home),
        folder=str(run_folder(machine, target.name, build_info["key"], testcase.path, entry.name, content)),
        source_folder=str(testcase.folder), files=testcase.files(), timeout=entry.timeout)
    if entry.script is not None and not entry.problems:
        spec.command = adapter.command(build_info["executable"], entry.script, variables, adapter.log_file(),
                                       mpi_prefix(target, config))
    return spec
