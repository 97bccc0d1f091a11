"""The session benchmark's MuJoCo converter (benchmarks/mujoco_scene.py): the robot and objects MuJoCo gets are
Drake's (masses, joints, limits, gains), and a short replay holds still what nothing touches and tracks the
telemetry. Skipped without MuJoCo (`pip install -e .[bench]`)."""
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pydrake")
mujoco = pytest.importorskip("mujoco", reason="mujoco not installed: pip install -e .[bench]")

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "benchmarks"))

from mujoco_replay import replay  # noqa: E402
from mujoco_scene import read_sdf, scene_xml  # noqa: E402

from bridge.recording.telemetry import Telemetry  # noqa: E402
from bridge.sim.scene import build_scene  # noqa: E402
from bridge.world import load_world_state  # noqa: E402


@pytest.fixture(scope="module")
def world(odb):
    return load_world_state(REPO / "demo" / "worlds" / "session.yaml", odb)


def test_the_converted_scene_has_drakes_bodies_masses_joints_and_gains(world, odb):
    scene = scene_xml(world, odb)
    model = mujoco.MjModel.from_xml_string(scene.xml)
    drake = build_scene(world, odb)
    plant = drake.plant
    context = plant.CreateDefaultContext()
    for name, body in drake.bodies.items():
        assert model.body_mass[model.body(name).id] == pytest.approx(body.get_mass(context))
    spec = odb.get(world.robot.type).robot
    _, joints = read_sdf(Path(spec.model))
    assert scene.actuated == spec.joints
    for name, kp, kd in zip(scene.actuated, scene.kp, scene.kd):
        joint = plant.GetJointByName(name, drake.robot_instance)
        mj = model.joint(name)
        assert tuple(mj.range) == pytest.approx((joint.position_lower_limits()[0], joint.position_upper_limits()[0]))
        assert (kp, kd) == joints[name].gains
        actuator = model.actuator(f"{name}_pd")
        assert actuator.gainprm[0] == kp and tuple(actuator.biasprm[:3]) == (0.0, -kp, -kd)
        assert actuator.forcerange[1] == pytest.approx(joints[name].effort)
    link_mass = sum(plant.get_body(i).get_mass(context) for i in plant.GetBodyIndices(drake.robot_instance))
    robot_bodies = [model.body(b).id for b in range(model.nbody) if model.body(b).name not in drake.bodies
                    and model.body(b).name != "world"]
    assert sum(model.body_mass[b] for b in robot_bodies) == pytest.approx(link_mass)


def test_a_short_replay_tracks_the_telemetry_and_leaves_resting_objects_alone(world, odb):
    spec = odb.get(world.robot.type).robot
    home = spec.home_positions()
    q0 = np.array([home[j] for j in spec.joints])
    q1 = q0.copy()
    q1[0] += 0.3  # turn the arm 0.3 rad about its base, high above the table
    times = np.arange(0.0, 2.0 + 1e-9, 0.02)
    s = np.clip(times / 1.5, 0, 1)
    positions = q0 + (3 * s**2 - 2 * s**3)[:, None] * (q1 - q0)
    run = replay(world, Telemetry(times, spec.joints, positions, source="<test>"), odb)
    result = run.result
    assert result.max_tracking_error < 0.02
    assert result.moved == () and result.touched_by_robot == ()
    for name, obj in world.objects.items():
        if name in result.tracks:
            assert result.final_poses[name].translation_to(obj.pose) < 0.001
    resting = {(c.body_a, c.body_b) for c in result.final_contacts if c.magnitude > 0}
    assert ("big_a", "table") in resting or ("table", "big_a") in resting
