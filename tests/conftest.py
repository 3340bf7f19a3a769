"""What the default run of the suite holds: every test but those marked ``slow``.

The slow tests are the long end-to-end runs: LIGGGHTS-PUBLIC built from git with a real C++ compiler, the
cross-code scenes and shapes, scaling over ranks, bisects over built commits, the whole collection, a few engine
scenes run several times to compare their bytes, and the store, CLI and dashboard suites run again on
PostgreSQL. ``--slow`` adds them; .ci/run runs them after the default run (``-m slow``), so that every commit is
checked with them. A marker expression that names ``slow`` (``-m slow``, ``-m "slow and liggghts"``) is honoured
as it is written, and a test named by its id (``tests/engine/test_jit.py::test_name``) runs whatever its marks.
"""
from __future__ import annotations

import os


def pytest_addoption(parser):
    parser.addoption("--slow", action="store_true", default=False,
                     help="also run the tests marked slow (long end-to-end runs: a real C++ build, cross-code scenes, "
                          "scaling); -m slow runs only them")


def _slow_included(config) -> bool:
    return config.getoption("--slow") or "slow" in (config.getoption("markexpr") or "")


def pytest_report_header(config):
    if not _slow_included(config):
        return "slow tests: left out (--slow runs them as well, -m slow only them)"
    return None


def _named(config) -> tuple[str, ...]:
    """Test ids given on the command line, relative to the root folder as pytest's node ids are."""
    root = str(config.rootpath)
    return tuple(os.path.relpath(os.path.abspath(path), root) + "::" + rest
                 for path, _, rest in (arg.partition("::") for arg in config.args if "::" in arg))


def pytest_collection_modifyitems(config, items):
    if _slow_included(config):
        return
    named = _named(config)
    slow = [item for item in items
            if item.get_closest_marker("slow") and not (named and item.nodeid.startswith(named))]
    if slow:
        config.hook.pytest_deselected(items=slow)
        left_out = set(map(id, slow))
        items[:] = [item for item in items if id(item) not in left_out]
