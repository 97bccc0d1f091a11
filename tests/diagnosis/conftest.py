"""Shared fixtures: the object database and small generated proof cases (real Drake)."""

import pytest

pytest.importorskip("pydrake")


@pytest.fixture(scope="session")
def planar_world(odb):
    from bridge.prove.scenes import nominal_world, scene_spec

    return nominal_world(scene_spec("planar", odb), odb, (0.0, 0.0, 0.1))
