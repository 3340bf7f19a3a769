"""The files people write: targets (``targets/NAME.json``), test cases (``run.config``) and what they declare
(sweeps, acceptance checks), read and validated from a git revision or the working tree.

Owns: targets, testcases, sweep, acceptance, revisions (``TARGET@REV``, ``A..B``), scaffold (``harness new``),
jsonfile (reading JSON input with problems that name file and field), gitrepo (git operations).
May import: ``harness.adapters`` (the code a target runs: its test case conventions) and
``harness.execution.workspace`` (where mirrors and exports live); never the store or the layers above.
"""
