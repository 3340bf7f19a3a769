"""(The folder is `builds`, not `build`: pytest does not collect folders named build.) Fixtures for the build tests: a throw-away store (as tests/harness/conftest.py), tiny C++ repositories,
and one ccache folder shared by the slow LIGGGHTS builds of a session."""
import os

import pytest
from store_fixtures import store_fixtures

django_store, store = store_fixtures("harness-build-tests-")


@pytest.fixture(scope="session")
def shared_ccache(tmp_path_factory):
    """One ccache folder for every slow LIGGGHTS build of the session: the second build of a commit next to
    a built one (or of the same commit in another workspace) compiles only what changed.
    ``HARNESS_TEST_CCACHE`` names a folder kept between sessions (a CI cache) instead of a fresh one."""
    kept = os.environ.get("HARNESS_TEST_CCACHE")
    return kept if kept else tmp_path_factory.mktemp("ccache")
