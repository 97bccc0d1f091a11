"""An MIT push as a bridge session: world layout, telemetry, observed track, a rod that starts inside the object."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.odb import load_object_database
from bridge.recording.mitpush import PUSHER_RADIUS, load_outline, load_push, signed_distance
from bridge.recording.mitsession import START_CLEARANCE, push_session

CLEAR = "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.800_t=-0.349.h5"  # the rod starts 1.6 mm away
INSIDE = "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.800_t=1.396.h5"  # 0.25 mm inside the outline


@pytest.fixture(scope="module")
def odb(mit_push_root):
    return load_object_database(datasets={"mit-push": mit_push_root})


def _clearance(session, outline):
    """Gap between the rod and the outline at t = 0 in the session's own frames."""
    pose = session.world.objects["rect1"].pose
    rel = np.array(session.telemetry.positions[0]) - np.array(pose.xyz[:2])
    c, s = math.cos(pose.yaw()), math.sin(pose.yaw())
    local = np.array([[c * rel[0] + s * rel[1], -s * rel[0] + c * rel[1]]])
    return float(signed_distance(local, outline)[0]) - PUSHER_RADIUS


def test_world_telemetry_and_observations(mit_push_root, odb):
    push = load_push(mit_push_root / "train" / CLEAR)
    session = push_session(push, odb, frame_yaw=0.3)
    world = session.world
    x0, y0, yaw0 = push.object_pose[0]
    surface, block = world.objects["surface"], world.objects["rect1"]
    assert surface.type == "push_surface" and surface.pose.xyz == pytest.approx((x0, y0, -0.005))  # top at z = 0
    assert block.type == "rect1" and block.pose.xyz == pytest.approx((x0, y0, 0.00635))  # mesh half height
    assert block.pose.yaw() == pytest.approx(math.remainder(yaw0 + 0.3, 2 * math.pi))
    assert world.robot.type == "planar_pusher" and world.robot.base_pose.xyz == pytest.approx((0, 0, 0.00635))
    assert session.telemetry.joint_names == ("pusher_x", "pusher_y")
    np.testing.assert_allclose(session.telemetry.positions, push.tip_xy)
    assert session.tip_shift == (0.0, 0.0) and not any("rod" in n for n in session.notes)
    assert session.start.clearance > 0 and not session.start.moved  # a start clear of the outline is kept too
    assert session.force is None and "ft_wrench not used" in session.notes[0]  # rect1: spikes only
    track = session.observations.track("rect1")
    assert np.allclose(np.diff(track.times)[:-1], 0.04) and track.times[-1] == pytest.approx(push.duration)
    assert track.poses[0].xyz == pytest.approx(block.pose.xyz)
    assert track.poses[-1].yaw() == pytest.approx(math.remainder(push.object_pose[-1, 2] + 0.3, 2 * math.pi))


def test_a_rod_starting_inside_is_moved_out_and_the_shift_is_kept(mit_push_root, odb):
    push = load_push(mit_push_root / "train" / INSIDE)
    outline = load_outline("rect1", mit_push_root)
    session = push_session(push, odb)
    shift = np.hypot(*session.tip_shift)
    assert 0.0002 < shift < 0.0005
    assert "inside the outline" in session.notes[0] and "moved" in session.notes[0]
    assert _clearance(session, outline) == pytest.approx(START_CLEARANCE, abs=1e-6)
    np.testing.assert_allclose(session.telemetry.positions - push.tip_xy, np.tile(session.tip_shift, (len(push), 1)))
    start = session.start  # the evidence, as data: what the shift undid and which way it went
    assert start.moved and start.shift == session.tip_shift and start.object == "rect1"
    assert start.penetration == pytest.approx(shift - START_CLEARANCE, abs=1e-9)
    np.testing.assert_allclose(np.array(start.shift) / shift, start.normal, atol=1e-9)
    assert session.notes[0] == start.text()
