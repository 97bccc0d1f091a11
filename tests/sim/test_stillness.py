"""Still spans (bridge/sim/stillness.py): a replay does not step while nothing moves and nothing is commanded to
move, and ends where the full simulation ends. Through the real Drake simulation: a steel block pushed on the
proof's plate by the planar rod, which waits beside it before the push and after it."""
from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.prove.scenes import nominal_world, scene_spec  # noqa: E402
from bridge.recording.telemetry import Telemetry  # noqa: E402
from bridge.sim.scene import build_scene  # noqa: E402
from bridge.sim.simulate import SimOptions, simulate  # noqa: E402
from bridge.sim.stillness import HOLD_TOLERANCE, hold_spans  # noqa: E402

JOINTS = ("pusher_x", "pusher_y")


def test_a_telemetry_holds_where_it_moves_less_than_the_tolerance():
    """Jitter within the tolerance is a hold; a ramp is not; the robot holds before its first and after its last
    sample."""
    t = np.arange(0.0, 1.0 + 1e-9, 0.1)
    x = np.where(t < 0.35, 0.0, np.where(t < 0.65, (t - 0.3) * 0.1, 0.035))
    x = x + np.where(np.arange(len(t)) % 2, 0.3, -0.3) * HOLD_TOLERANCE  # encoder jitter
    spans = hold_spans(t, np.column_stack([x, np.zeros_like(x)]))
    assert spans[0] == (-math.inf, pytest.approx(0.3))
    assert spans[-1] == (pytest.approx(0.7), math.inf)
    assert all(not (0.35 < a < 0.65 or 0.35 < b < 0.65) for a, b in spans)  # the ramp holds nowhere


@pytest.fixture(scope="module")
def scene(odb):
    spec = scene_spec("planar", odb)
    world = nominal_world(spec, odb, (0.0, 0.0, 0.0))
    return spec, world, build_scene(world, odb)


def push(speed: float, wait: float = 0.4, length: float = 0.03, after: float = 0.6) -> Telemetry:
    """The rod 3 mm from the block's -x face, still for `wait`, along +x at `speed` for `length`, still after."""
    start = -0.045 - 0.00476 - 0.003
    t = np.round(np.arange(0.0, wait + length / speed + after, 0.004), 6)
    x = start + np.clip(t - wait, 0.0, length / speed) * speed
    return Telemetry(t, JOINTS, np.column_stack([x, np.full_like(x, 0.01)]))


@pytest.mark.parametrize("speed", [0.05, 0.4])
def test_a_push_skips_the_rods_waits_and_ends_as_the_full_simulation(scene, speed):
    """The rod waits beside the block before the push and rests against it after; the replay steps neither wait
    (its awake spans leave them out: a third of the replay or more), yet every sample of the block's track is the
    full simulation's within 0.05 mm and 0.05 deg, and so is the force on the rod while it moves. At 0.4 m/s the
    block slides on after the rod stops: it is stepped until it stands still."""
    _, world, built = scene
    telemetry = push(speed)
    options = SimOptions(sample_rate=50.0, robot_force=True)
    full = simulate(built, telemetry, world=world, options=SimOptions(sample_rate=50.0, robot_force=True, sleep=False))
    held = simulate(built, telemetry, world=world, options=options)
    stepped = sum(b - a for a, b in held.awake)
    assert stepped < 0.7 * full.sim_time
    gap = np.linalg.norm(held.tracks["block"][:, :3] - full.tracks["block"][:, :3], axis=1)
    assert gap.max() < 5e-5
    dots = np.abs(np.sum(held.tracks["block"][:, 3:] * full.tracks["block"][:, 3:], axis=1))
    assert np.degrees(2 * np.arccos(np.clip(dots.min(), -1, 1))) < 0.05
    moving = (held.times > 0.4) & (held.times < 0.4 + 0.03 / speed)
    np.testing.assert_allclose(held.robot_force[moving], full.robot_force[moving], atol=0.05)
    block_moved = np.linalg.norm(full.tracks["block"][-1, :2] - full.tracks["block"][0, :2])
    assert block_moved > 0.02  # the push really moved it
    if speed > 0.1:  # it slid on after the rod stopped: no span was held while it slid
        stop = 0.4 + 0.03 / speed
        sliding = np.linalg.norm(np.diff(full.tracks["block"][:, :2], axis=0), axis=1) / np.diff(full.times) > 1e-3
        last_slide = full.times[1:][sliding].max()
        assert last_slide > stop + 0.02
        assert any(a <= last_slide <= b for a, b in held.awake)


def test_an_object_that_starts_to_move_is_not_held(scene, odb):
    """A block released just above the plate (nothing commanded: the rod never moves) falls onto it: it is
    stepped while it falls and settles, and then held."""
    spec, world, built = scene
    from dataclasses import replace

    from bridge.values import Pose

    block = world.objects["block"]
    lifted = replace(block, pose=Pose((block.pose.xyz[0], block.pose.xyz[1], block.pose.xyz[2] + 0.002),
                                      block.pose.quat))
    dropped = replace(world, objects={**world.objects, "block": lifted})
    telemetry = Telemetry(np.array([0.0, 1.0]), JOINTS, np.array([[-0.1, 0.1], [-0.1, 0.1]]))
    options = SimOptions(sample_rate=50.0)
    full = simulate(built, telemetry, world=dropped, options=SimOptions(sample_rate=50.0, sleep=False))
    held = simulate(built, telemetry, world=dropped, options=options)
    z_full, z_held = full.tracks["block"][:, 2], held.tracks["block"][:, 2]
    landed = full.times[np.argmax(z_full < z_full[0] - 0.0015)]
    assert held.awake[0][1] > landed  # stepped at least until it landed
    np.testing.assert_allclose(z_held, z_full, atol=2e-5)
