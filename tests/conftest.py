"""Shared fixtures. Tests that need ../shared/data use ``shared_data``: they skip with a reason
when it is absent, and fail instead when GPEXPLORE_REQUIRE_DATA=1 (as in CI)."""

import os

import pytest

from sim.data import shared_data_dir


@pytest.fixture(scope="session")
def shared_data():
    path = shared_data_dir()
    if path is None:
        reason = "shared data not found: set GPEXPLORE_DATA or place it at ../shared/data"
        if os.environ.get("GPEXPLORE_REQUIRE_DATA") == "1":
            pytest.fail(reason + " (GPEXPLORE_REQUIRE_DATA=1)")
        pytest.skip(reason)
    return path
