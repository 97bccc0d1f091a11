"""Sleeping objects, through the real Drake simulation: objects at rest out of reach are held and not simulated,
wake before anything can touch them, and every replay ends where the full simulation ends (facts, and final
poses within 1 mm / 1 deg)."""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.fit.synthetic import push_world  # noqa: E402
from bridge.recording.recording import load_recording, recording_world  # noqa: E402
from bridge.recording.telemetry import Telemetry  # noqa: E402
from bridge.rollout import Rollout  # noqa: E402
from bridge.sim.scene import SceneValues, build_scene  # noqa: E402
from bridge.sim.simulate import SimOptions, simulate  # noqa: E402
from bridge.sim.sleep import SleepRules  # noqa: E402
from bridge.teleop import run_session  # noqa: E402
from bridge.values import Pose  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
DEMO = sorted(p for p in (REPO / "demo" / "recordings").iterdir() if (p / "world.yaml").is_file())
JOINTS = ("pusher_x", "pusher_y")


@pytest.fixture(scope="module")
def world():
    """The synthetic push world with the rod 10 cm higher: out of reach of the table (a rod skimming the table
    keeps the replay stepping: the table could stop it)."""
    plain = push_world()
    base = plain.robot.base_pose
    raised = Pose((base.xyz[0], base.xyz[1], base.xyz[2] + 0.1), base.quat)
    return replace(plain, robot=replace(plain.robot, base_pose=raised))


@pytest.fixture(scope="module")
def scene(world, odb):
    return build_scene(world, odb)


def lane(end: float, y: float = -0.3) -> Telemetry:
    """The rod back and forth along a lane of the table 30 cm from the boxes."""
    t = np.round(np.arange(0.0, end + 1e-9, 0.01), 6)
    x = 0.5 + 0.2 * np.sin(2 * math.pi * t / end)
    return Telemetry(t, JOINTS, np.column_stack([x, np.full_like(x, y)]))


_SESSIONS: dict = {}


def session(folder: Path, odb, sleep: bool = True):
    """The demo trial replayed (once per module) with or without sleeping objects."""
    if (folder, sleep) not in _SESSIONS:
        recording = load_recording(folder)
        _SESSIONS[folder, sleep] = run_session(Rollout(recording_world(recording, odb), recording.telemetry), odb,
                                               options=SimOptions(sleep=sleep))
    return _SESSIONS[folder, sleep]


def pose_gap(a: Pose, b: Pose) -> tuple[float, float]:
    return 1000 * a.translation_to(b), math.degrees(a.rotation_to(b))


def test_objects_out_of_reach_sleep_and_the_robot_follows_its_telemetry(scene):
    """The boxes come to rest in 0.2 s and the rod never comes near them or the table: from then on nothing is
    stepped until the
    last sample interval (stepped in full, so the final contacts are the full simulation's), the boxes' tracks
    stand still and the rod's joints are its telemetry."""
    telemetry = lane(3.0)
    result = simulate(scene, telemetry, options=SimOptions(joint_track=True))
    assert result.awake == ((0.0, SleepRules().rest_time), tuple(result.times[-2:]))
    after = (result.times > SleepRules().rest_time) & (result.times <= result.times[-2])
    for track in result.tracks.values():
        assert np.all(track[after] == track[after][0])
    np.testing.assert_allclose(result.joint_track[after], [telemetry.sample(t) for t in result.times[after]],
                               atol=1e-12)


def test_held_objects_do_not_drift_under_forces_and_an_offset_centre_of_mass(scene, world):
    """A sleeper is held by cancelling its weight and any external force at its centre of mass: with a force
    the table's friction holds and a centre of mass moved off the middle, it ends where the full simulation
    ends it."""
    mass = 0.2  # the big box's order of magnitude; the force stays well inside its friction cone
    values = (SceneValues().with_force("big_box", (0.3 * mass * 9.81 * 0.2, 0.0, 0.0))
              .with_object("big_box", com=(0.02, 0.01, 0.0)))
    options = dict(end=2.0)
    full = simulate(scene, lane(2.0), values=values, options=SimOptions(sleep=False, **options))
    held = simulate(scene, lane(2.0), values=values, options=SimOptions(**options))
    assert held.awake == ((0.0, SleepRules().rest_time), tuple(held.times[-2:]))
    for name in full.final_poses:
        dx, dr = pose_gap(full.final_poses[name], held.final_poses[name])
        assert dx < 0.01 and dr < 0.01, (name, dx, dr)


def test_an_object_starting_in_the_air_falls_before_it_sleeps(scene, world, odb):
    """Zero velocity at t = 0 is no rest: a box that starts 3 cm above the table lands as in the full
    simulation."""
    box = world.objects["small_box"]
    lifted = Pose((box.pose.xyz[0], box.pose.xyz[1], box.pose.xyz[2] + 0.03), box.pose.quat)
    up = replace(world, objects={**world.objects, "small_box": replace(box, pose=lifted)})
    full = simulate(scene, lane(1.5), world=up, options=SimOptions(sleep=False))
    held = simulate(scene, lane(1.5), world=up, options=SimOptions())
    z = held.final_poses["small_box"].xyz[2]
    assert z < lifted.xyz[2] - 0.025  # it fell
    assert pose_gap(full.final_poses["small_box"], held.final_poses["small_box"])[0] < 0.01


def test_the_robot_is_stepped_before_it_nears_an_object_and_the_object_wakes_before_the_touch(odb):
    """Pushing a box over: the box sleeps while the arm approaches; the arm is stepped again (it leaves its
    telemetry's kinematic path) at least the PD settling time before the first touch, while the box still
    sleeps; the box wakes before the touch, and the push ends as in the full simulation that made the
    recording."""
    asleep = session(REPO / "demo" / "recordings" / "1_push_over", odb)
    replay = asleep.replay
    first_touch = min(c.time for c in replay.contact_log if c.involves("arm") and "big_box" in (c.body_a, c.body_b))
    stepped = max(start for start, _ in replay.awake if start < first_touch)
    assert stepped > 1.0  # followed kinematically during the approach ...
    assert first_touch - stepped > 0.1  # ... and stepped well before the touch
    track, times = replay.tracks["big_box"], replay.times[1:]
    held = times[np.all(track[1:] == track[:-1], axis=1)]  # a sleeper's pose is held exactly
    woken = held[held < first_touch].max()
    assert stepped < woken < first_touch  # the arm stepped beside a sleeping box, the box awake for the touch
    assert sum(b - a for a, b in replay.awake) < 0.5 * replay.sim_time
    assert "(upright big_box)" not in {str(f) for f in asleep.inference.world.facts}


@pytest.mark.slow
@pytest.mark.parametrize("folder", DEMO, ids=[p.name for p in DEMO])
def test_every_demo_trial_ends_as_the_full_simulation(folder, odb):
    """observed.csv of the demo trials holds the final poses of the full simulation that made them: with
    sleeping objects the replay ends within 1 mm / 1 deg of them, and the facts equal the full replay's."""
    recording = load_recording(folder)
    asleep, full = session(folder, odb), session(folder, odb, sleep=False)
    assert asleep.inference.world.facts == full.inference.world.facts
    for name in recording.observations.objects:
        dx, dr = pose_gap(recording.observations.track(name).poses[-1], asleep.replay.final_poses[name])
        assert dx < 1.0 and dr < 1.0, (name, dx, dr)
        dx, dr = pose_gap(full.replay.final_poses[name], asleep.replay.final_poses[name])
        assert dx < 1.0 and dr < 1.0, (name, dx, dr)
