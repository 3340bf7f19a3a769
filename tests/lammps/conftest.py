"""Fixtures for the LAMMPS tests (helpers in lammps_support.py)."""
from __future__ import annotations

from pathlib import Path

import pytest

from lammps_support import FREE_FALL, LMP, run_lammps


@pytest.fixture(scope="session")
def free_fall_run(tmp_path_factory):
    """A finished serial LAMMPS run of FREE_FALL (about 0.5 s)."""
    if not Path(LMP).exists():
        pytest.skip("LAMMPS not installed (apt-get install lammps)")
    folder = tmp_path_factory.mktemp("free_fall")
    (folder / "in.free_fall").write_text(FREE_FALL)
    result = run_lammps(folder, "in.free_fall")
    assert result.returncode == 0, result.stdout + result.stderr
    return folder
