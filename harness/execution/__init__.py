"""Building targets and running test cases: the build recipes and their cache, the run spec, the scheduler
that runs them on a thread pool or Dask, one run's execution and post-processing, the workspace's folders
and locks, sampling profiles, and garbage collection of old folders.

Owns: builds, planning (the run spec), scheduler (``run_targets``: plan, claim, execute, store), execute (one
run in a worker), postprocess (series from a run's files), profiles, workspace, gc.
May import: ``harness.adapters``, ``harness.config``, ``harness.store`` (records, rules; models inside
functions) and ``harness.analysis.coverage`` (the run configurations a verdict covers are recorded as they
are planned); never ``harness.report`` or the commands.
"""
