"""Fixtures for the YADE tests (helpers in yade_testing.py)."""
from __future__ import annotations

from pathlib import Path

import pytest

from yade_testing import FALL, YADE, run_yade


@pytest.fixture(scope="session")
def fall_run(tmp_path_factory):
    """A finished YADE run of FALL through the harness' launcher (about 3 s)."""
    if not Path(YADE).exists():
        pytest.skip("YADE not installed (apt-get install yade)")
    folder = tmp_path_factory.mktemp("fall")
    (folder / "fall.py").write_text(FALL)
    (folder / "post").mkdir()
    process = run_yade(folder, "fall.py", {"steps": 1000, "label": "first"})
    assert process.returncode == 0, (folder / "stderr.txt").read_text()
    return folder
