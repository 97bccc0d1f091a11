"""Models: settings applied in order to a rollout, families built once, targets checked, and what they do in the
real Drake simulation."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.errors import ParameterError
from bridge.fit.synthetic import push_telemetries, push_world
from bridge.params import KINDS, Kind, Setting, apply_model, kind_named, parse_params, register_kind
from bridge.rollout import Rollout, run_rollout
from bridge.sim.simulate import SimOptions


@pytest.fixture(scope="module")
def world():
    return push_world()


@pytest.fixture(scope="module")
def rollout(world):
    return Rollout(world, push_telemetries()["slide"])


def test_settings_write_scene_values_and_telemetry(rollout, odb):
    spec = parse_params({"params": [
        {"kind": "friction", "target": "type:box", "bounds": [0.1, 1]},
        {"kind": "friction", "target": "pusher/pusher_rod", "bounds": [0.1, 1]},
        {"kind": "com_x", "target": "big_box", "bounds": [-0.05, 0.05]},
        {"kind": "com_z", "target": "big_box", "bounds": [-0.05, 0.05]},
        {"kind": "force_y", "target": "small_box", "bounds": [-1, 1]},
        {"kind": "latency", "target": "pusher", "bounds": [0, 0.2]},
        {"kind": "joint_offset", "target": "pusher_y", "bounds": [-0.01, 0.01]},
        {"kind": "mass", "target": "small_box", "value": 0.7},
        {"kind": "mass_spread", "target": "small_box", "value": 0.0},
    ]})
    out = apply_model(spec.model([0.4, 0.2, 0.01, -0.02, 0.5, 0.05, 0.003]), rollout, odb)
    values, tel = out.values, out.telemetry
    assert values.objects["big_box"].friction == values.objects["small_box"].friction == 0.4  # type:box: both
    assert values.objects["pusher/pusher_rod"].friction == 0.2
    assert values.objects["big_box"].com == pytest.approx((0.01, 0.0, -0.02))  # the other axes keep the database's
    assert values.objects["small_box"].mass == 0.7 and values.objects["small_box"].spread == 0.0
    assert values.external_forces["small_box"] == (0.0, 0.5, 0.0)
    np.testing.assert_allclose(tel.times, rollout.telemetry.times + 0.05)
    np.testing.assert_allclose(tel.positions[:, 1], rollout.telemetry.positions[:, 1] + 0.003)
    np.testing.assert_allclose(tel.positions[:, 0], rollout.telemetry.positions[:, 0])
    assert "table" not in values.objects and not out.extras  # nothing else touched
    assert rollout.telemetry.times[0] == 0.0 and not rollout.values.objects  # the input is unchanged


def test_family_members_build_one_thing_with_the_others_at_null(rollout, world, odb):
    post = apply_model((Setting("obstacle_x", "table", 0.9),), rollout, odb)
    (extra,) = post.extras
    null_y = kind_named("obstacle_y").null(world, odb, "table")
    assert extra.shape == "cylinder" and extra.xyz[:2] == (0.9, null_y)
    both = apply_model((Setting("obstacle_y", "table", 0.1), Setting("obstacle_x", "table", 0.9)), rollout, odb)
    assert len(both.extras) == 1 and both.extras[0].xyz[:2] == (0.9, 0.1)  # one post, whatever the order
    tilt = apply_model((Setting("surface_slope_x", "table", 0.02), Setting("surface_slope_y", "table", -0.01)),
                       rollout, odb)
    turned = tilt.world.objects["table"].pose.rotation_to(world.objects["table"].pose)
    assert turned == pytest.approx(math.hypot(0.02, 0.01), rel=1e-6)
    for name in ("big_box", "small_box"):  # what stands on the table keeps its x, y and tilts with it
        assert tilt.world.objects[name].pose.xyz[:2] == pytest.approx(world.objects[name].pose.xyz[:2])
    patch = apply_model((Setting("patch_cx", "table", 0.7), Setting("patch_mu", "table", 0.1)), rollout, odb)
    (sheet,) = patch.extras
    assert sheet.friction == 0.1 and sheet.region == pytest.approx((0.65, 0.75, -0.05, 0.05))


def test_a_target_that_names_nothing_is_an_error_naming_the_world(rollout, odb):
    with pytest.raises(ParameterError, match="com_x\\[bigbox\\]: 'bigbox' names nothing in world 'synthetic_push'; "
                                             "objects: big_box, small_box"):
        apply_model((Setting("com_x", "bigbox", 0.01),), rollout, odb)
    assert apply_model((Setting("com_x", "bigbox", 0.01),), rollout, odb, strict=False) is rollout


def test_a_new_kind_is_registered_explicitly(rollout, odb):
    class TableFriction(Kind):
        name = "test_table_friction"
        doc = "friction of the table, twice the value (a test kind)"
        targets = "surfaces"

        def apply(self, value, names, rollout, odb):
            return rollout.with_values(rollout.values.with_object(names[0], friction=2 * value))

    with pytest.raises(ParameterError, match="unknown kind 'test_table_friction'"):
        parse_params({"params": [{"kind": "test_table_friction", "target": "table", "value": 0.3}]})
    register_kind(TableFriction())
    try:
        spec = parse_params({"params": [{"kind": "test_table_friction", "target": "table", "value": 0.3}]})
        assert apply_model(spec.model(), rollout, odb).values.objects["table"].friction == pytest.approx(0.6)
    finally:
        del KINDS["test_table_friction"]


@pytest.mark.slow
def test_a_tilted_surface_in_a_parameter_file_tilts_the_replay(world, odb):
    """`surface_slope_x` rotates the table and what stands on it in the simulation itself: the lying box rests on
    the tilted top, tilted with it (the real tilt, not a force standing in for it)."""
    still = Rollout(world, push_telemetries()["slide"].shifted(5.0))  # the rod waits: nothing is pushed
    spec = parse_params({"params": [{"kind": "surface_slope_x", "target": "table", "value": 0.05}]})
    tilted = apply_model(spec.model(), still, odb)
    result = run_rollout(tilted, odb, SimOptions(end=0.5))
    final = result.final_poses["small_box"]
    assert final.rotation_to(world.objects["small_box"].pose) == pytest.approx(0.05, abs=0.005)
    level = run_rollout(still, odb, SimOptions(end=0.5)).final_poses["small_box"]
    assert level.rotation_to(world.objects["small_box"].pose) < 0.005


def test_settings_that_reproduce_the_world_model_leave_the_canonical_model(world, odb):
    """A candidate at its null values is the model without it (a diagnosis evaluates it once); settings whose null
    does not reproduce the world model (a friction coefficient also sets the dynamic one, a post at its null place
    is still a post) stay."""
    from bridge.params import canonical_model
    from bridge.sim.shapes import mass_properties

    m0 = float(mass_properties(odb, "small_box").mass)
    com0 = [float(c) for c in mass_properties(odb, "small_box").com]
    friction = Setting("friction", "big_box", 0.4)
    nulls = (Setting("com_x", "small_box", com0[0]), Setting("mass", "small_box", m0),
             Setting("mass_spread", "small_box", 0.0), Setting("latency", "pusher", 0.0),
             Setting("surface_slope_x", "table", 0.0), Setting("force_z", "small_box", 0.0))
    assert canonical_model((friction, *nulls), world, odb) == (friction,)
    moved = Setting("mass", "small_box", 2 * m0)
    assert canonical_model((friction, moved, Setting("mass_spread", "small_box", 0.0)), world, odb) == (
        friction, moved, Setting("mass_spread", "small_box", 0.0))  # the spread matters beside a changed mass
    kept = (Setting("friction", "table", kind_named("friction").null(world, odb, "table")),
            Setting("obstacle_x", "table", kind_named("obstacle_x").null(world, odb, "table")))
    assert canonical_model(kept, world, odb) == kept


def test_a_null_setting_replays_as_the_world_model(rollout, world, odb):
    """What `null_is_world` promises, in Drake: the same tracks with and without the settings it drops."""
    from bridge.params import canonical_model
    from bridge.sim.shapes import mass_properties

    mp = mass_properties(odb, "small_box")
    model = (Setting("mass", "small_box", float(mp.mass)), Setting("com_y", "small_box", float(mp.com[1])),
             Setting("latency", "pusher", 0.0), Setting("mass_spread", "small_box", 0.0))
    assert canonical_model(model, world, odb) == ()
    options = SimOptions(settle=0.2)
    a, b = run_rollout(apply_model(model, rollout, odb), odb, options), run_rollout(rollout, odb, options)
    for name, track in b.tracks.items():
        assert np.array_equal(a.tracks[name], track)


def test_a_joint_offset_is_relative_to_the_raw_recording_in_every_trial(world, odb):
    """The loader moved one recording's tip out of the object (`StartClearance.shift`); an offset says where the
    rod really was relative to the raw recording, so it replaces that shift there and is added as it is where
    nothing was moved; zero keeps the loader's repair."""
    from pathlib import Path

    from bridge.params import trial_rollout
    from bridge.recording.adjustments import StartClearance
    from bridge.rollout.trials import Trial

    telemetry = push_telemetries()["slide"]
    shift = (0.002, -0.001)
    moved = Trial("moved", world, telemetry.with_offsets({"pusher_x": shift[0], "pusher_y": shift[1]}), None,
                  Path("moved"), adjustments=(StartClearance("small_box", -0.002, (1.0, 0.0), shift, 1e-4, 0.05),))
    kept = Trial("kept", world, telemetry, None, Path("kept"))
    offset = (Setting("joint_offset", "pusher_x", 0.005), Setting("joint_offset", "pusher_y", 0.0))
    for trial in (moved, kept):
        tel = trial_rollout(trial, offset, odb).telemetry
        columns = [tel.joint_names.index(j) for j in ("pusher_x", "pusher_y")]
        raw = telemetry.positions[:, [telemetry.joint_names.index(j) for j in ("pusher_x", "pusher_y")]]
        # x: raw + 5 mm in both; y: zero offset keeps what the loader made (the repair in the moved one)
        np.testing.assert_allclose(tel.positions[:, columns[0]], raw[:, 0] + 0.005, atol=1e-12)
        expected_y = raw[:, 1] + (shift[1] if trial is moved else 0.0)
        np.testing.assert_allclose(tel.positions[:, columns[1]], expected_y, atol=1e-12)
