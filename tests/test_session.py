"""Scripted sessions (bridge/session.py): a short one made the way the session benchmark makes its 5-minute one
is a recording bridge loads, its free motion touches nothing, its contact phases are its actions', and its replay
gives the facts the plan's effects predict."""
from pathlib import Path

import numpy as np
import pytest

from bridge.session import SHORT_SESSION, contact_phases, free_share, overlap
from bridge.sim.simulate import ReplayResult
from bridge.values import Contact

REPO = Path(__file__).resolve().parents[1]


def _result(contacts, end=10.0):
    times = np.arange(0.0, end + 1e-9, 0.02)
    return ReplayResult(times, {}, (), tuple(contacts), (), (), 0.0, end, 1.0)


def test_contact_phases_join_short_gaps_and_ignore_the_robot_touching_itself():
    touch = [Contact("arm/finger_left", "box", (0, 0, 1), (0, 0, 0), t) for t in (1.0, 1.02, 1.3, 4.0, 4.02)]
    touch += [Contact("box", "table", (0, 0, 1), (0, 0, 0), t) for t in (6.0, 7.0)]  # not the robot
    touch += [Contact("arm/hand", "arm/finger_left", (0, 0, 1), (0, 0, 0), 8.0)]  # the robot itself
    result = _result(touch)
    assert contact_phases(result, "arm") == ((1.0, 1.3), (4.0, 4.02))
    assert contact_phases(result, "arm", merge_gap=0.1) == ((1.0, 1.02), (1.3, 1.3), (4.0, 4.02))
    assert free_share(contact_phases(result, "arm"), 10.0) == pytest.approx(1 - 0.32 / 10)
    assert overlap(((0.0, 2.0), (5.0, 6.0)), ((1.0, 5.5),)) == pytest.approx(1.5)


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    pytest.importorskip("pydrake")
    from bridge.odb import load_object_database
    from bridge.planning import load_action_templates
    from bridge.session import make_session

    odb = load_object_database()
    templates = load_action_templates(REPO / "pddl" / "templates", odb)
    return make_session(SHORT_SESSION, tmp_path_factory.mktemp("sessions") / "short_session", odb, templates)


@pytest.mark.slow
def test_a_short_session_is_a_recording_bridge_check_passes(short, capsys):
    from bridge.cli import main

    assert main(["check", str(short.recording.folder)]) == 0
    assert capsys.readouterr().out.strip().endswith("ok")
    files = sorted(p.name for p in short.recording.folder.iterdir())
    assert files == ["observed.csv", "recording.yaml", "telemetry.csv", "world.yaml"]
    assert "2 contact phases" in short.recording.notes


@pytest.mark.slow
def test_free_motion_fills_the_session_and_touches_nothing(short):
    plan = SHORT_SESSION
    assert short.recording.telemetry.duration == pytest.approx(plan.duration, abs=1.0)
    assert short.free_motion[0] == (0.0, pytest.approx(plan.lead_in, abs=0.05))
    assert len(short.free_motion) == 3  # before the push, after it, after the place (none while holding the box)
    assert overlap(short.phases, short.free_motion) == 0.0
    assert len(short.phases) == 2  # the push over; the pick and the place (the box never leaves the fingers)
    free = sum(b - a for a, b in short.free_motion)
    assert short.free_share >= free / short.enactment.replay.sim_time


@pytest.mark.slow
def test_the_replayed_facts_are_the_plans_effects(short):
    done = short.enactment
    assert done.matches
    facts = set(map(str, done.after.facts))
    assert {"(on small_box tray)", "(in small_box tray)", "(hand-empty arm)"} <= facts
    assert "(upright big_box)" not in facts
    observed = {track.object: track.poses[-1] for track in short.recording.observations.tracks}
    for name, pose in done.replay.final_poses.items():
        assert observed[name].translation_to(pose) < 1e-5


@pytest.mark.slow
def test_sleeping_objects_replay_the_session_as_the_full_simulation_does(short):
    """`bridge infer`'s default replay (sleeping objects) against every object stepped: the same facts, final
    poses within 1 mm / 1 deg, and most of the session not stepped at all."""
    from bridge.odb import load_object_database
    from bridge.sim.simulate import SimOptions
    from bridge.teleop import infer_recording

    odb = load_object_database()
    asleep = infer_recording(short.recording, odb)
    full = infer_recording(short.recording, odb, options=SimOptions(sleep=False))
    assert asleep.inference.world.facts == full.inference.world.facts
    for name, pose in full.replay.final_poses.items():
        other = asleep.replay.final_poses[name]
        assert pose.translation_to(other) < 1e-3 and pose.rotation_to(other) < np.radians(1.0), name
    stepped = sum(b - a for a, b in asleep.replay.awake)
    assert stepped < 0.6 * asleep.replay.sim_time  # the free motion (60 % of the session) is not stepped
