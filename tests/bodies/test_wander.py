"""Operator free motion (bridge/bodies/wander.py): it fills its time, keeps clear of every object, ends at home,
and the same generator gives the same motion."""
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.bodies import wander  # noqa: E402
from bridge.bodies.motion import RATE  # noqa: E402
from bridge.bodies.wander import FIXTURE_CLEARANCE, MOVABLE_CLEARANCE  # noqa: E402
from bridge.sim.kinematics import arm_for, clearance_for  # noqa: E402
from bridge.world import load_world_state  # noqa: E402

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def world(odb):
    return load_world_state(REPO / "demo" / "worlds" / "session.yaml", odb)


def test_free_motion_lasts_its_time_keeps_clear_and_ends_home(world, odb):
    tel = wander(world, odb, 20.0, np.random.default_rng(3))
    assert tel.duration == pytest.approx(20.0, abs=1.0 / RATE)
    assert np.max(np.diff(tel.times)) <= 1.0 / RATE + 1e-6
    spec = odb.get(world.robot.type).robot
    home = spec.home_positions()
    np.testing.assert_allclose(tel.positions[-1], [home[j] for j in spec.joints], atol=1e-6)
    start = world.robot.joint_positions()
    np.testing.assert_allclose(tel.positions[0], [start[j] for j in spec.joints], atol=1e-6)
    clearance = clearance_for(world, odb)
    fixed = {n for n, o in world.objects.items() if odb.get(o.type).fixed}
    for q in tel.positions[::10]:
        for name, (distance, link) in clearance.distances(q).items():
            assert distance >= (FIXTURE_CLEARANCE if name in fixed else MOVABLE_CLEARANCE) - 1e-3, (name, link)
    arm = arm_for(world, odb)
    tcp = np.array([arm.pose(q, "tcp")[0] for q in tel.positions[::25]])
    assert np.ptp(tcp[:, 0]) > 0.1 or np.ptp(tcp[:, 1]) > 0.1  # it goes somewhere


def test_the_same_generator_gives_the_same_free_motion(world, odb):
    a = wander(world, odb, 8.0, np.random.default_rng(7))
    b = wander(world, odb, 8.0, np.random.default_rng(7))
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.times, b.times)
    c = wander(world, odb, 8.0, np.random.default_rng(8))
    assert not np.array_equal(a.positions, c.positions)
