"""The one simulation loop, through the real Drake simulation: where the robot starts and how it holds, the
sample grid, what each option records, context hooks and callbacks, and the one failure policy (every failure
a `SimulationFailure` saying what happened and when, never garbage handed on)."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.errors import RecordingError, SimulationFailure  # noqa: E402
from bridge.fit.synthetic import push_telemetries, push_world  # noqa: E402
from bridge.recording.telemetry import Telemetry  # noqa: E402
from bridge.sim.extras import WeldedShape  # noqa: E402
from bridge.sim.friction import combined_friction  # noqa: E402
from bridge.sim.scene import SceneValues, build_scene  # noqa: E402
from bridge.sim.simulate import FailurePolicy, SimOptions, simulate  # noqa: E402
from bridge.values import Pose  # noqa: E402

G = 9.81
JOINTS = ("pusher_x", "pusher_y")
LANE_Y = -0.3  # a lane on the table, clear of the boxes (both at y = 0, 10 cm wide at most)
ROD_RADIUS = 0.00476


@pytest.fixture(scope="module")
def world():
    return push_world()


@pytest.fixture(scope="module")
def scene(world, odb):
    return build_scene(world, odb)


@pytest.fixture(scope="module")
def slide():
    return push_telemetries()["slide"]


def lane_telemetry(x0: float, x1: float, move: tuple[float, float], end: float, dt: float = 0.01) -> Telemetry:
    """The rod along the free lane: still at x0, moving to x1 between move[0] and move[1], then still."""
    t = np.round(np.arange(0.0, end + 1e-9, dt), 6)
    x = np.interp(t, [0.0, *move, end], [x0, x0, x1, x1])
    return Telemetry(t, JOINTS, np.column_stack([x, np.full_like(x, LANE_Y)]))


# --- the sample grid and the robot's start and end -------------------------------------------------------------
def test_samples_run_from_zero_to_the_telemetry_end_plus_settle(scene):
    """Tracks are compared with observations sample by sample: the grid is exactly 0, 1/rate, ..., and `end`."""
    tel = lane_telemetry(0.3, 0.4, (0.1, 0.3), 0.4)
    result = simulate(scene, tel, options=SimOptions(sample_rate=25.0, settle=0.2))
    np.testing.assert_allclose(result.times, np.arange(16) / 25.0)  # 0 .. 0.6 s
    assert result.sim_time == pytest.approx(0.6)
    assert all(track.shape == (16, 7) for track in result.tracks.values())
    assert result.moved == ()  # the rod stayed in its lane
    explicit = simulate(scene, tel, options=SimOptions(sample_rate=10.0, end=0.33))
    np.testing.assert_allclose(explicit.times, [0.0, 0.1, 0.2, 0.3, 0.33])  # `end` is the last; none past it


def test_the_robot_starts_at_its_telemetry_and_holds_its_first_sample_until_it_starts(scene):
    """Telemetry shifted by a latency may start before t = 0 (the robot starts mid-way, where it is at t = 0)
    or after it (the robot waits at the first sample)."""
    tel = lane_telemetry(0.3, 0.4, (0.1, 0.3), 0.4)
    early = tel.shifted(-0.15)  # starts at -0.15 s: at t = 0 the rod is a quarter of the way
    result = simulate(scene, early, options=SimOptions(settle=0.15, joint_track=True))
    assert result.joint_names == JOINTS
    np.testing.assert_array_equal(result.joint_track[0], early.sample(0.0))
    assert result.joint_track[0, 0] == pytest.approx(0.325)
    assert result.times[-1] == pytest.approx(0.25 + 0.15)  # the shifted telemetry's end + settle
    assert result.max_tracking_error < 0.005

    moving = lane_telemetry(0.3, 0.4, (0.0, 0.2), 0.3)  # moves from its first sample on, at 0.5 m/s
    late = moving.shifted(0.2)
    result = simulate(scene, late, options=SimOptions(settle=0.1, joint_track=True))
    np.testing.assert_array_equal(result.joint_track[0], moving.positions[0])
    waiting = result.times < 0.2  # held still until then, not led by the first segment's velocity
    assert waiting.sum() == 10
    np.testing.assert_allclose(result.joint_track[waiting], np.tile(moving.positions[0], (10, 1)), atol=1e-6)
    assert result.joint_track[-1, 0] == pytest.approx(0.4, abs=1e-4)
    assert result.times[-1] == pytest.approx(0.5 + 0.1)


def test_after_the_last_sample_the_robot_comes_to_rest_there(scene):
    """Telemetry that ends while the rod moves at 0.5 m/s: after the end the desired velocity is zero, so the
    PD controller stops the rod at the last sample instead of leading it by the velocity term."""
    t = np.round(np.arange(0.0, 0.3 + 1e-9, 0.01), 6)
    x = 0.3 + 0.5 * np.clip(t - 0.1, 0.0, None)
    tel = Telemetry(t, JOINTS, np.column_stack([x, np.full_like(x, LANE_Y)]))
    result = simulate(scene, tel, options=SimOptions(settle=0.3, joint_track=True))
    after = result.times > tel.end + 0.15
    assert after.sum() >= 5
    np.testing.assert_allclose(result.joint_track[after, 0], tel.positions[-1, 0], atol=2e-4)
    assert np.ptp(result.joint_track[after, 0]) < 1e-5  # at rest, not creeping on


def test_without_telemetry_the_robot_holds_the_worlds_joints(scene, world):
    """A replay with no telemetry (objects just settling) must leave the robot where the world state puts it,
    not drive it to joint zeros across the scene."""
    seen = []

    class RobotJoints:
        def start(self, scene, context, values):
            return seen

        def update(self, scene, context, t, poses, state):
            plant_ctx = scene.plant.GetMyContextFromRoot(context)
            state.append(scene.plant.GetPositions(plant_ctx, scene.robot_instance).copy())

    simulate(scene, None, hooks=(RobotJoints(),), options=SimOptions(settle=0.2))
    expected = scene.robot_positions(world.robot.joint_positions())
    assert expected[0] > 0.4
    np.testing.assert_allclose(seen[0], expected)
    np.testing.assert_allclose(seen[-1], expected, atol=1e-3)


def test_telemetry_columns_may_come_in_any_order(scene, slide):
    """Bags list joints in their own order: the replay maps columns to actuators by name."""
    swapped = Telemetry(slide.times, tuple(reversed(slide.joint_names)), slide.positions[:, ::-1])
    options = SimOptions(settle=0.0, joint_track=True)
    a, b = simulate(scene, slide, options=options), simulate(scene, swapped, options=options)
    np.testing.assert_array_equal(b.joint_track, a.joint_track)
    for name, track in a.tracks.items():
        np.testing.assert_array_equal(b.tracks[name], track, err_msg=name)
    assert b.max_tracking_error == a.max_tracking_error < 0.01


def test_telemetry_for_another_robot_is_a_recording_error(scene):
    """Checked before anything is simulated, naming the joint the robot lacks."""
    tel = Telemetry(np.array([0.0, 0.1]), ("arm_joint1", "pusher_x"), np.zeros((2, 2)))
    with pytest.raises(RecordingError, match="telemetry joint 'arm_joint1' is not a joint of the robot"):
        simulate(scene, tel)


# --- the failure policy --------------------------------------------------------------------------------------
@pytest.mark.parametrize("force, message", [
    ((0.0, 0.0, -1.0e4), r"object 'small_box' went through 'table' at t = 0\.02 s"),
    ((200.0, 0.0, 0.0), r"object 'small_box' moves at [1-9]\d\.\d m/s at t = 0\.0[2-9]0 s \(diverged\)"),
    ((float("nan"), 0.0, 0.0), r"Drake stopped at t = 0\.000 s: .*NaN"),
])
def test_garbage_physics_is_a_failure_saying_what_and_when(scene, slide, force, message):
    """A force that presses the small box through the rigid table, one that throws it at tens of m/s, and one
    that is not a number: the replay stops at once with what happened, instead of handing on tracks."""
    with pytest.raises(SimulationFailure, match=message):
        simulate(scene, slide, values=SceneValues().with_force("small_box", force), options=SimOptions(settle=0.0))


def test_an_object_below_the_world_fell_out(scene, world):
    """Checked at every sample, the first (t = 0) included."""
    lost = world.with_poses({"small_box": Pose((2.0, 0.0, -6.0))})
    with pytest.raises(SimulationFailure, match=r"object 'small_box' fell out of the world at t = 0\.00 s"):
        simulate(scene, None, world=lost, options=SimOptions(end=0.1))


def test_speed_limits_are_the_policys(scene, slide):
    """The slide shoves the big box at 0.9 m/s: fine by default, a failure under a stricter policy, for an
    object's speed (max_speed) or any joint's (max_velocity: the rod itself moves that fast)."""
    result = simulate(scene, slide, options=SimOptions(settle=0.0))
    assert set(result.moved) == {"big_box", "small_box"}
    with pytest.raises(SimulationFailure, match=r"object 'big_box' moves at 0\.\d m/s at t = 0\.\d+ s"):
        simulate(scene, slide, options=SimOptions(settle=0.0, policy=FailurePolicy(max_speed=0.5)))
    with pytest.raises(SimulationFailure, match=r"the simulation diverged at t = 0\.\d+ s"):
        simulate(scene, slide, options=SimOptions(settle=0.0, policy=FailurePolicy(max_velocity=0.5)))


@pytest.fixture(scope="module")
def blocked(world, odb):
    """A post in the rod's lane (its near face at x = 0.39) and telemetry that drives the rod through it to
    x = 0.8: the real robot met nothing there."""
    post = WeldedShape("post", "box", (0.02, 0.1, 0.1), (0.4, LANE_Y, 0.8))
    return build_scene(world, odb, extras=(post,)), lane_telemetry(0.3, 0.8, (0.1, 0.4), 0.8)


def test_a_robot_held_back_cannot_follow_its_telemetry(blocked):
    scene, tel = blocked
    with pytest.raises(SimulationFailure, match=r"the robot cannot follow its telemetry: joint 'pusher_x' is "
                                                r"0\.\d+ off at t = 0\.[5-8]\d s"):
        simulate(scene, tel, options=SimOptions(settle=0.0))


def test_without_the_tracking_check_the_held_back_robot_is_replayed(blocked):
    """The viewer shows where the robot got stuck: the rod stays at the post, pressing on it with all its
    actuator can give (200 N), and the post is no object, so the rod touched nothing inference cares about."""
    scene, tel = blocked
    result = simulate(scene, tel, options=SimOptions(settle=0.0, joint_track=True, robot_force=True, contacts=True,
                                                     policy=FailurePolicy(check_tracking=False)))
    face = 0.4 - 0.01 - ROD_RADIUS
    assert np.max(result.joint_track[:, 0]) < face + 0.002  # a millimetre into the post at the impact, at most
    assert result.joint_track[-1, 0] == pytest.approx(face, abs=0.001)
    np.testing.assert_allclose(result.robot_force[-1], (-200.0, 0.0, 0.0), atol=2.0)
    assert ("pusher/pusher_rod", "world") in result.contact_pairs() and result.touched_by_robot == ()
    assert result.max_tracking_error > 0.1  # how far behind it fell is still reported


# --- what is recorded ----------------------------------------------------------------------------------------
def test_by_default_nothing_costly_is_recorded(scene, slide):
    """A fit runs thousands of replays: contacts, the rod's force and its joints only when asked for."""
    result = simulate(scene, slide, options=SimOptions(settle=0.1))
    assert result.contact_log == () and result.final_contacts == () and result.touched_by_robot == ()
    assert result.robot_force is None and result.joint_track is None
    assert result.joint_names == JOINTS and result.robot == "pusher"


def test_contacts_robot_force_and_joints_when_asked(scene, slide, odb):
    """The contact log holds every contact at every sample, named as inference reads them, with the force on
    body_b by body_a: a box sliding free of the rod feels Coulomb friction (the combined mu times its weight,
    against its motion), a box at rest only its weight. The force on the rod pushes back against the shove."""
    result = simulate(scene, slide, options=SimOptions(settle=0.1, contacts=True, robot_force=True, joint_track=True))
    T = len(result.times)
    assert {c.time for c in result.contact_log} <= set(result.times.tolist())
    pairs = {frozenset(p) for p in result.contact_pairs()}
    assert {frozenset(("table", "big_box")), frozenset(("table", "small_box")), frozenset(("big_box", "small_box")),
            frozenset(("pusher/pusher_rod", "big_box"))} <= pairs
    assert all(name in ("table", "big_box", "small_box", "pusher/pusher_rod") for pair in pairs for name in pair)
    assert result.touched_by_robot == ("big_box",)

    def table_on(name, t):
        return sum((np.asarray(c.force) * (1 if c.body_a == "table" else -1) for c in result.contact_log
                    if c.time == t and {c.body_a, c.body_b} == {"table", name}), np.zeros(3))

    k = 15  # 0.3 s: the rod backed off at 0.22 s, the boxes still slide in +x
    free = float(result.times[k])
    assert free == pytest.approx(0.3) and np.all(result.robot_force[k] == 0.0)
    for name, mass in (("big_box", 1.0), ("small_box", 0.3)):
        mu = combined_friction(odb.get("table").physics.friction, odb.get(name).physics.friction)
        assert result.tracks[name][k + 1, 0] - result.tracks[name][k - 1, 0] > 0.005  # sliding
        sliding = table_on(name, free)
        assert sliding[2] == pytest.approx(mass * G, rel=0.01)
        np.testing.assert_allclose(sliding[:2], (-mu * mass * G, 0.0), atol=0.02 * mass * G, err_msg=name)
        np.testing.assert_allclose(table_on(name, float(result.times[-1])), (0.0, 0.0, mass * G),
                                   atol=0.01 * mass * G, err_msg=name)

    assert result.robot_force.shape == (T, 3)
    assert np.all(result.robot_force[0] == 0.0)  # 1 mm from the box: nothing yet
    assert np.min(result.robot_force[:, 0]) < -5.0  # shoving a 1 kg box to 0.9 m/s: the box pushes back (-x)
    assert np.max(result.robot_force[:, 0]) < 1.0  # a rod pushing in +x is never pulled forward
    assert result.joint_track.shape == (T, 2) and result.joint_names == JOINTS
    np.testing.assert_allclose(result.joint_track, slide.sample(np.clip(result.times, 0, slide.end)), atol=0.01)


def test_final_contacts_include_near_pairs(scene):
    """The lying boxes stand 0.5 mm apart: inference needs them as touching at the end, though no force flows."""
    tel = lane_telemetry(0.3, 0.35, (0.05, 0.15), 0.2)
    result = simulate(scene, tel, options=SimOptions(settle=0.1, final_contacts=True))
    assert result.contact_log == ()
    pairs = {frozenset((c.body_a, c.body_b)): c for c in result.final_contacts}
    assert set(pairs) == {frozenset(p) for p in (("table", "big_box"), ("table", "small_box"),
                                                  ("big_box", "small_box"))}
    assert pairs[frozenset(("big_box", "small_box"))].magnitude == 0.0
    assert pairs[frozenset(("table", "big_box"))].magnitude == pytest.approx(G, rel=0.01)
    assert {c.time for c in result.final_contacts} == {float(result.times[-1])}


# --- hooks and callbacks -------------------------------------------------------------------------------------
class LateShove:
    """From the first sample after `after` s on, a sideways force on one object, written into the context."""

    def __init__(self, name: str, force: tuple[float, float, float], after: float):
        self.name, self.force, self.after = name, force, after

    def start(self, scene, context, values):
        return {"values": values, "calls": []}

    def update(self, scene, context, t, poses, state):
        state["calls"].append((t, dict(poses)))
        if t > self.after:
            forces = dict(state["values"].external_forces)
            forces[self.name] = self.force
            scene.force_source.set_forces(scene.force_source.GetMyMutableContextFromRoot(context), forces)


def test_a_context_hook_changes_the_running_replay_and_only_it(scene):
    """Diagnosis models effects that start mid-replay with hooks: the force acts from the sample after the hook
    wrote it, the hook sees every sample's poses once, and the next replay is untouched."""
    tel = lane_telemetry(0.3, 0.35, (0.05, 0.15), 0.3)
    options = SimOptions(settle=0.2, sleep=False)  # a replay with hooks simulates everything: compare like with like
    plain = simulate(scene, tel, options=options)
    states = []

    class Recording(LateShove):
        def start(self, scene, context, values):
            state = super().start(scene, context, values)
            states.append(state)
            return state

    values = SceneValues()
    shoved = simulate(scene, tel, values=values, hooks=(Recording("small_box", (0.0, 3.0, 0.0), 0.2),),
                      options=options)
    (state,) = states
    assert state["values"] is values
    assert [t for t, _ in state["calls"]] == shoved.times.tolist()
    for (t, poses), k in zip(state["calls"], range(len(shoved.times))):
        assert set(poses) == {"big_box", "small_box"}
        assert poses["small_box"].xyz == pytest.approx(tuple(shoved.tracks["small_box"][k, :3]), abs=1e-12)
    first = int(np.argmax(shoved.times > 0.2))  # the sample at which the hook first writes the force
    np.testing.assert_array_equal(shoved.tracks["small_box"][: first + 1], plain.tracks["small_box"][: first + 1])
    # 3 N against mu m g = 0.5 * 0.3 * 9.81 = 1.5 N of friction: the small box slides off in +y
    assert shoved.tracks["small_box"][-1, 1] > plain.tracks["small_box"][-1, 1] + 0.02
    assert "small_box" in shoved.moved and "small_box" not in plain.moved
    again = simulate(scene, tel, options=options)
    np.testing.assert_array_equal(again.tracks["small_box"], plain.tracks["small_box"])


def test_on_sample_and_progress_see_every_sample(scene, slide):
    """The on-line estimate reads poses and contacts at every sample, even when the log is not kept."""
    samples, ticks = [], []
    result = simulate(scene, slide, options=SimOptions(settle=0.1),
                      on_sample=lambda t, poses, contacts: samples.append((t, dict(poses), list(contacts))),
                      progress=lambda t, end: ticks.append((t, end)))
    times = result.times.tolist()
    assert [t for t, _, _ in samples] == times
    assert ticks == [(t, times[-1]) for t in times]
    for k, (t, poses, contacts) in enumerate(samples):
        for name, pose in poses.items():
            assert pose.xyz == pytest.approx(tuple(result.tracks[name][k, :3]), abs=1e-12)
        assert all(c.time == t for c in contacts)
    pushing = [t for t, _, contacts in samples if any(c.involves("pusher") for c in contacts)]
    assert pushing and 0.0 < pushing[0] < 0.2  # the rod meets the box early in the shove
    assert result.contact_log == ()  # seen by the callback, not kept
