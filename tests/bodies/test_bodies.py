"""Action bodies: their telemetry, replayed in Drake and run through the SIEs, gives exactly the facts the action
templates' effects give; and the pushes obey the quasi-static tipping condition."""
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.enactment import enact, make_recording  # noqa: E402
from bridge.errors import ActionError  # noqa: E402
from bridge.inference import infer_state  # noqa: E402
from bridge.odb.geometry import support  # noqa: E402
from bridge.planning import apply_action, load_action_templates  # noqa: E402
from bridge.recording.recording import load_recording  # noqa: E402
from bridge.bodies import BODIES, push_at, world_after_replay  # noqa: E402
from bridge.bodies.motion import RATE  # noqa: E402
from bridge.sim.kinematics import arm_for  # noqa: E402
from bridge.enactment import REPLAY  # noqa: E402
from bridge.params import Setting, apply_model  # noqa: E402
from bridge.rollout import Rollout, run_rollout  # noqa: E402
from bridge.world import load_world_state, world_from_dict  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
TABLETOP = REPO / "demo" / "worlds" / "tabletop.yaml"
TOPPLED = REPO / "tests" / "fixtures" / "worlds" / "toppled.yaml"

# the demo's trials (demo/make_demo.py) and the stand-up of the toppled small box
CASES = {
    "push_over": (TABLETOP, ("arm", "big_box", "table")),
    "push": (TABLETOP, ("arm", "big_box", "table")),
    "push_against": (TABLETOP, ("arm", "small_box", "big_box", "table")),
    "pick": (TABLETOP, ("arm", "small_box", "table")),
    "stand_up": (TOPPLED, ("arm", "small_box", "work_table")),
}


@pytest.fixture(scope="module")
def templates(odb):
    return load_action_templates(REPO / "pddl" / "templates", odb)


class Run:
    """One body's telemetry replayed: the world before, the replay, the inferred and the expected worlds."""

    def __init__(self, world, action, args, odb, templates):
        self.world, self.action, self.args = world, action, args
        self.telemetry = BODIES[action](world, odb, list(args))
        self.result = run_rollout(Rollout(world, self.telemetry), odb, REPLAY)
        self.inferred = infer_state(world, odb, self.result.final_poses, self.result.final_contacts,
                                    self.result.moved, self.result.contact_pairs())
        self.expected = apply_action(world, odb, templates, action, list(args))


@pytest.fixture(scope="module")
def runs(odb, templates):
    """Replays shared by the tests of this module, made on first use."""
    cache = {}

    def get(action):
        if action not in cache:
            if action == "place":
                picked = get("pick")
                held = world_after_replay(picked.world, picked.result, picked.inferred.world.facts)
                cache[action] = Run(held, "place", ("arm", "small_box", "tray"), odb, templates)
            else:
                path, args = CASES[action]
                cache[action] = Run(load_world_state(path, odb), action, args, odb, templates)
        return cache[action]

    return get


def facts(world):
    return sorted(map(str, world.facts))


# --- the effects ----------------------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("action", ["push_over", "push", "push_against", "pick", "place", "stand_up"])
def test_replayed_body_gives_exactly_the_templates_effects(action, runs):
    run = runs(action)
    assert not run.inferred.failures
    assert facts(run.inferred.world) == facts(run.expected)
    obj = run.args[1]
    assert obj in run.result.moved


@pytest.mark.slow
def test_place_starts_with_the_object_between_the_fingers(runs, odb):
    run = runs("place")
    joints = run.world.robot.joint_positions()
    assert 0.02 < joints["finger_left_joint"] < 0.03  # stopped by the 5 cm box, not closed
    first = dict(zip(run.telemetry.joint_names, run.telemetry.positions[0]))
    assert all(first[j] == pytest.approx(v, abs=1e-6) for j, v in joints.items())  # telemetry starts there
    arm = arm_for(run.world, odb)
    for t in (0.5, 2.0):  # lifting and carrying: the box moves with the tcp
        k = int(np.searchsorted(run.result.times, t))
        tcp_moved = arm.pose(run.result.joint_track[k], "tcp")[0] - arm.pose(run.result.joint_track[0], "tcp")[0]
        box_moved = run.result.pose_at("small_box", t).position - run.world.objects["small_box"].pose.position
        assert np.linalg.norm(tcp_moved) > 0.01
        assert np.linalg.norm(box_moved - tcp_moved) < 0.002


@pytest.mark.slow
def test_pick_then_place_in_one_telemetry(odb, templates):
    world = load_world_state(TABLETOP, odb)
    done = enact(world, odb, templates, [("pick", ("arm", "small_box", "table")), ("place", ("arm", "small_box", "tray"))])
    assert facts(done.after) == facts(done.expected)
    assert {"(on small_box tray)", "(in small_box tray)", "(hand-empty arm)"} <= set(facts(done.after))
    assert done.telemetry.duration < 40


@pytest.mark.slow
def test_an_object_nobody_touched_keeps_its_facts_and_pose(runs):
    run = runs("push_over")
    for name in ("small_box", "tray"):
        assert name not in run.result.moved
        assert name not in run.result.touched_by_robot
        assert name not in run.inferred.evaluated
        assert run.result.final_poses[name].translation_to(run.world.objects[name].pose) < 0.001
        before = {f for f in run.world.facts if name in f.args}
        assert {f for f in run.inferred.world.facts if name in f.args} == before


# --- the telemetry --------------------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("action", ["push_over", "push_against", "pick", "place", "stand_up"])
def test_telemetry_is_all_joints_at_50_hz_from_the_world_to_home_at_moderate_speed(action, runs, odb):
    run = runs(action)
    tel = run.telemetry
    spec = odb.get(run.world.robot.type).robot
    assert tel.joint_names == spec.joints
    dt = np.diff(tel.times)
    assert np.all(dt <= 1.0 / RATE + 1e-6) and np.median(dt) == pytest.approx(1.0 / RATE)
    start = run.world.robot.joint_positions()
    np.testing.assert_allclose(tel.positions[0], [start[j] for j in spec.joints], atol=1e-6)
    if action != "pick":  # pick ends holding the object up
        home = spec.home_positions()
        np.testing.assert_allclose(tel.positions[-1], [home[j] for j in spec.joints], atol=1e-6)
    arm = arm_for(run.world, odb)
    for frame in ("tcp", "fingertip"):
        points = np.array([arm.pose(q, frame)[0] for q in tel.positions])
        speed = np.linalg.norm(np.diff(points, axis=0), axis=1) / dt
        near = np.array([_distance_to_objects(run, odb, p, t) < 0.05 for p, t in zip(points[1:], tel.times[1:])])
        assert near.any()
        assert speed[near].max() <= 0.1, f"{frame} moves at {speed[near].max():.3f} m/s near an object"


def _distance_to_objects(run, odb, point, t):
    """Distance from `point` to the nearest movable object's world bounding box, where the replay had it at `t`."""
    best = np.inf
    for name, obj in run.world.objects.items():
        kind = odb.get(obj.type)
        if kind.fixed:
            continue
        pose = run.result.pose_at(name, t)
        hi = np.array([support(kind.geometry, pose, e) for e in np.eye(3)])
        lo = -np.array([support(kind.geometry, pose, -e) for e in np.eye(3)])
        best = min(best, float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - point, point - hi)))))
    return best


# --- errors ---------------------------------------------------------------------------------------------------
def test_bad_arguments_name_the_action_and_the_object(odb):
    world = load_world_state(TABLETOP, odb)
    with pytest.raises(ActionError, match=r"push_over\(arm, cup, table\): unknown object 'cup' for the object"):
        BODIES["push_over"](world, odb, ["arm", "cup", "table"])
    with pytest.raises(ActionError, match=r"'justin' is not the world's robot; the robot is 'arm'"):
        BODIES["pick"](world, odb, ["justin", "small_box", "table"])
    with pytest.raises(ActionError, match=r"pick\(arm, tray, table\): 'tray' is wider than 6 cm"):
        BODIES["pick"](world, odb, ["arm", "tray", "table"])
    with pytest.raises(ActionError, match=r"stand_up\(arm, big_box, table\): 'big_box' is not lying on its side"):
        BODIES["stand_up"](world, odb, ["arm", "big_box", "table"])
    with pytest.raises(ActionError, match=r"place\(arm, small_box, tray\): 'small_box' at .* is not in the gripper"):
        BODIES["place"](world, odb, ["arm", "small_box", "tray"])
    with pytest.raises(ActionError, match="push_over takes 3 arguments"):
        BODIES["push_over"](world, odb, ["arm", "big_box"])


def test_unreachable_object_names_the_target_point(odb):
    world = _box_world(odb, (1.08, 0.52))  # the far corner of the table
    with pytest.raises(ActionError) as info:
        BODIES["push"](world, odb, ["arm", "big_box", "table"])
    message = str(info.value)
    assert message.startswith("push(arm, big_box, table): no way to")
    assert "'big_box'" in message and ("puts the fingertip at (" in message or "would leave 'table'" in message)


def test_a_box_with_no_free_side_to_fall_on_is_not_pushed_over(odb):
    world = _box_world(odb, (0.60, 0.0), others={"small_box": (0.60, 0.14), "cup": (0.60, -0.14), "bottle": (0.76, 0.0)})
    with pytest.raises(ActionError) as info:
        BODIES["push_over"](world, odb, ["arm", "big_box", "table"])
    message = str(info.value)
    assert message.startswith("push_over(arm, big_box, table): no way to push 'big_box' over: ")
    for blocker in ("'small_box'", "'cup'", "'bottle'"):
        assert f"would come within 3 cm of {blocker}" in message
    assert "would leave 'table'" in message  # towards the robot: off the table's edge


# --- physics: quasi-static tipping ------------------------------------------------------------------------------
def _box_world(odb, xy, others=None):
    types = {"small_box": ("small_box", 0.81), "cup": ("cup", 0.80), "bottle": ("bottle", 0.87)}
    objects = {"table": {"type": "table", "pose": {"xyz": [0.75, 0.0, 0.725]}},
               "big_box": {"type": "big_box", "pose": {"xyz": [xy[0], xy[1], 0.875]}}}
    for name, (x, y) in (others or {}).items():
        objects[name] = {"type": types[name][0], "pose": {"xyz": [x, y, types[name][1]]}}
    return world_from_dict({"name": "box", "objects": objects,
                            "robot": {"name": "arm", "type": "demo_arm", "pose": {"xyz": [0, 0, 0.75]}},
                            "facts": ["(on big_box table)", "(upright big_box)", "(clear big_box)", "(hand-empty arm)"]},
                           odb)


@pytest.fixture(scope="module")
def tipping_world(odb):
    return _box_world(odb, (0.65, 0.0))


@pytest.mark.slow
@pytest.mark.parametrize("mu", [0.4, 0.8])
@pytest.mark.parametrize("factor", [0.7, 1.4])
def test_tall_box_tips_when_pushed_above_w_over_2mu_and_slides_below(mu, factor, tipping_world, odb, templates):
    """Box and table at friction mu, nearly frictionless pads (the theory's pusher): pushed at `factor` times the
    tipping height w / (2 mu), the 10 cm wide box tips above it and slides upright below it."""
    world = tipping_world
    w, H = 0.1, 0.25
    threshold = w / (2 * mu)
    phi = np.arctan2(w, H)
    travel = 1.4 * (1.4 * threshold * np.tan(phi) - w * (1 / np.cos(phi) - 1)) + 0.02  # enough to tip the high push
    telemetry = push_at(world, odb, ["arm", "big_box", "table"], (1, 0, 0), factor * threshold, travel)
    model = (Setting("friction", "big_box", mu), Setting("friction", "table", mu),
             Setting("friction", "arm/finger_left", 0.05), Setting("friction", "arm/finger_right", 0.05))
    result = run_rollout(apply_model(model, Rollout(world, telemetry), odb), odb, REPLAY)
    box = result.final_poses["big_box"]
    tilt = np.degrees(np.arccos(np.clip(box.z_axis()[2], -1, 1)))
    inferred = infer_state(world, odb, result.final_poses, result.final_contacts, result.moved, result.contact_pairs())
    if factor > 1:
        assert tilt == pytest.approx(90, abs=5)
        assert facts(inferred.world) == facts(apply_action(world, odb, templates, "push_over", ["arm", "big_box", "table"]))
    else:
        assert tilt < 3
        assert box.xyz[0] - 0.65 > travel - 0.03  # it slid with the pusher
        assert facts(inferred.world) == facts(world)


# --- recordings -----------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_make_recording_writes_a_folder_that_reads_back(odb, templates, tmp_path):
    out = tmp_path / "pick"
    recording = make_recording(TABLETOP, "pick", ["arm", "small_box", "table"], out, odb, templates)
    again = load_recording(out)
    assert (out / "world.yaml").read_text() == TABLETOP.read_text()
    assert "(pick arm small_box table)" in again.notes and "equal the templates' effects" in again.notes
    assert again.robot == "demo_arm"
    assert len(again.telemetry) == len(recording.telemetry)
    track = again.observations.track("small_box")
    assert len(track) == 2 and track.final().xyz[2] > track.initial().xyz[2] + 0.1
    with pytest.raises(ActionError, match=r"precondition \(on small_box big_box\) does not hold"):
        make_recording(TABLETOP, "pick", ["arm", "small_box", "big_box"], tmp_path / "bad", odb, templates)


def _demo_trials():
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_demo", REPO / "demo" / "make_demo.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.TRIALS


@pytest.mark.slow
def test_shipped_demo_recordings_are_what_make_demo_makes(odb, templates):
    """demo/make_demo.py reproduces the shipped telemetry; its trials are the actions replayed above (1-3) and the
    pick-then-place sequence (4), so the shipped recordings give the templates' facts too."""
    from bridge.enactment import plan_telemetry

    trials = _demo_trials()
    assert set(trials) == {p.name for p in (REPO / "demo" / "recordings").iterdir() if p.is_dir()}
    for name, steps in trials.items():
        recording = load_recording(REPO / "demo" / "recordings" / name)
        assert recording.observations is not None and recording.robot == "demo_arm"
        assert all(str((action, *args)).replace("'", "").replace(",", "") in recording.notes for action, args in steps)
        world = load_world_state(recording.world_path, odb)
        telemetry, _ = plan_telemetry(world, odb, templates, steps)
        assert telemetry.joint_names == recording.telemetry.joint_names
        np.testing.assert_allclose(telemetry.times, recording.telemetry.times, atol=1e-6)
        np.testing.assert_allclose(telemetry.positions, recording.telemetry.positions, atol=1e-5)  # 6 decimals; 4 follows a simulation
        if len(steps) == 1:
            action, args = steps[0]
            assert CASES[action] == (TABLETOP, args)
