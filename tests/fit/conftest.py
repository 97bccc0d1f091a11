"""Shared, expensive things for the fit tests: the object database, the synthetic push trials, one process pool."""
from __future__ import annotations

import pytest

pytest.importorskip("pydrake")

from bridge.fit.synthetic import push_trials  # noqa: E402
from bridge.rollout import make_executor  # noqa: E402


@pytest.fixture(scope="session")
def trials(odb):
    """The synthetic push scenario ('slide', 'turn') observed with `synthetic.TRUE_VALUES`."""
    return push_trials(odb)


@pytest.fixture(scope="session")
def slide(trials):
    return [t for t in trials if t.name == "slide"]


@pytest.fixture(scope="session")
def pool(odb):
    """Two spawned worker processes, shared by the slow tests (spawning and importing Drake costs seconds)."""
    with make_executor("process", odb, workers=2) as executor:
        yield executor
