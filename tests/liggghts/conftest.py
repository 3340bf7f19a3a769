"""Fixtures for the LIGGGHTS tests (helpers in liggghts_support.py)."""
from __future__ import annotations

from pathlib import Path

import pytest

from liggghts_support import FREE_FALL, LIGGGHTS, run_liggghts


@pytest.fixture(scope="session")
def free_fall_run(tmp_path_factory):
    """A finished serial LIGGGHTS run of FREE_FALL (about 0.3 s)."""
    if not Path(LIGGGHTS).exists():
        pytest.skip("LIGGGHTS not installed (apt-get install liggghts)")
    folder = tmp_path_factory.mktemp("free_fall")
    (folder / "in.free_fall").write_text(FREE_FALL)
    result = run_liggghts(folder, "in.free_fall")
    assert result.returncode == 0, result.stdout + result.stderr
    return folder
