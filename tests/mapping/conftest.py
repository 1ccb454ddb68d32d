"""Fixtures: small simulated worlds."""

import pytest

from simworlds import corridor_world, room_world


@pytest.fixture(scope="module")
def corridor():
    return corridor_world()


@pytest.fixture(scope="module")
def room():
    return room_world()
