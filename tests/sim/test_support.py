"""Where an object's weight rests (`bridge/sim/support.py`, the `pressure_distribution` effect's kinds): a
footprint scaled and moved as real contact geometry, through real Drake pushes of the proof's steel block."""
import math

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.diagnosis.effects import Evidence, get_effect  # noqa: E402
from bridge.errors import SceneError  # noqa: E402
from bridge.params.model import Setting, apply_model  # noqa: E402
from bridge.params.kinds import kind_named  # noqa: E402
from bridge.rollout.rollout import run_rollout  # noqa: E402
from bridge.sim.support import SupportPressure, bottom_polygon, gyration_radius  # noqa: E402


@pytest.fixture(scope="module")
def push(block_pushes):
    """A push that turns the block by ~45 deg."""
    return block_pushes[0]


@pytest.fixture(scope="module")
def turn_and_travel(block_track):
    def measure(rollout, odb):
        track = block_track(rollout)
        q = track[:, 3:7]
        yaw = np.unwrap(2 * np.arctan2(q[:, 3], q[:, 0]))
        return math.degrees(yaw[-1] - yaw[0]), float(np.linalg.norm(track[-1, :2] - track[0, :2]))

    return measure


def test_a_concentrated_footprint_turns_a_push_more_and_a_wide_one_less(push, odb, turn_and_travel):
    own = turn_and_travel(push, odb)
    same = turn_and_travel(push.with_extras(SupportPressure("block", 1.0)), odb)
    small = turn_and_travel(push.with_extras(SupportPressure("block", 0.6)), odb)
    wide = turn_and_travel(push.with_extras(SupportPressure("block", 1.3)), odb)
    assert abs(own[0]) > 20  # the push turns the block
    # the footprint at scale 1 carries the block as its own bottom does
    assert abs(same[0] - own[0]) < 0.5 and abs(same[1] - own[1]) < 5e-4
    # less torsional friction: the same push turns it more; more: less; the sign stays
    assert small[0] > own[0] * 1.1 and 0 < wide[0] < own[0] * 0.95


def test_a_disc_of_the_same_radius_of_gyration_turns_it_about_alike(push, odb, turn_and_travel):
    """Why the proof may conceal the effect as a disc: what a push sees is the footprint's radius of gyration."""
    poly, _, _ = bottom_polygon(odb.get("steel_block"), 16)
    radius = math.sqrt(2) * 0.6 * gyration_radius(poly)
    a = np.linspace(0, 2 * math.pi, 16, endpoint=False)
    disc = tuple((radius * math.cos(t), radius * math.sin(t)) for t in a)
    scaled = turn_and_travel(push.with_extras(SupportPressure("block", 0.6)), odb)[0]
    as_disc = turn_and_travel(push.with_extras(SupportPressure("block", polygon=disc)), odb)[0]
    own = turn_and_travel(push, odb)[0]
    assert abs(as_disc - scaled) < 0.35 * abs(scaled - own)


def test_the_kinds_add_a_support_only_off_their_null_values(push, odb):
    model = (Setting("support_scale", "block", 0.7), Setting("support_x", "block", 0.004))
    out = apply_model(model, push, odb)
    assert out.extras == (SupportPressure("block", 0.7, (0.004, 0.0)),)
    assert apply_model((Setting("support_scale", "block", 1.0),), push, odb).extras == ()
    assert "centre of pressure outside 'block'" in kind_named("support_y").check_on(0.5, ("block",), push, odb)
    assert kind_named("support_y").check_on(0.01, ("block",), push, odb) is None
    assert "support_scale 3 is outside the physical range" in kind_named("support_scale").check_value(3.0)


def test_bad_supports_name_the_object(push, odb):
    with pytest.raises(SceneError, match="no free object 'surface'"):
        run_rollout(push.with_extras(SupportPressure("surface", 0.5)), odb)
    with pytest.raises(SceneError, match="scale must be in"):
        run_rollout(push.with_extras(SupportPressure("block", 0.0)), odb)
    with pytest.raises(SceneError, match="counter-clockwise"):
        run_rollout(push.with_extras(SupportPressure("block", polygon=((0, 0), (0, 0.01), (0.01, 0)))), odb)


def test_gyration_radius_of_a_square_and_a_disc():
    assert gyration_radius(np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)])) == pytest.approx(math.sqrt(2 / 3))
    a = np.linspace(0, 2 * math.pi, 400, endpoint=False)
    assert gyration_radius(np.column_stack([np.cos(a), np.sin(a)]) + 5.0) == pytest.approx(math.sqrt(0.5), rel=1e-3)


def test_the_signature_tells_a_common_turn_factor_from_an_off_centre_mass(push, odb):
    effect = get_effect("pressure_distribution")

    def evidence(ratios):
        return Evidence(tuple({"turn_ratio": r, "significant": True} for r in ratios), push.world, odb)

    common = evidence([1.6, 1.5, 1.8, 1.4])
    mixed = evidence([1.6, 0.6, 1.5, 0.7])
    assert effect.signature(common, "block") > 0.5 > 0.2 > effect.signature(mixed, "block")
    seeds = effect.seeds(common, "block")
    assert seeds[1]["support_scale[block]"] == pytest.approx(1.55 ** -0.5, abs=0.05)


def test_no_footprint_twists_wider_than_the_objects_own_farthest_points(push, odb):
    """The largest spread of weight a bottom allows: all of it at its points farthest from the centroid, sqrt 2
    radii of gyration out on a disc, sqrt 3 on a square. `support_scale` searches no further: a fit that asks for
    more wants the weight off the object, so its model family is wrong (at a bound, never a finding)."""
    from bridge.sim.support import widest_scale

    assert widest_scale(odb.get("steel_block")) == pytest.approx(math.sqrt(3), rel=1e-6)
    lo, hi = kind_named("support_scale").bounds(push.world, odb, "block")
    assert (lo, hi) == (0.3, pytest.approx(math.sqrt(3)))


def test_a_footprint_scaled_by_s_twists_as_the_weight_s_times_as_far_out(push, odb, spin_down):
    """What `support_scale` means, as Drake has it: spun on the plate, the block on a footprint at scale s turns
    1/s as far as on its own bottom (torsional friction mu m g <r>, the weight's mean distance from the centre s
    times as large). The same spin-down shows Drake's own fan of a mesh twisting by where it stands
    (`tests/sim/test_prisms.py`)."""
    def turn(*extras):
        return spin_down(push.world, odb, "block", push.config, push.values, extras)

    own = turn()
    assert math.degrees(own) > 20  # a spin the block really slides through, not a stick
    for scale in (0.7, 1.3):
        assert own / turn(SupportPressure("block", scale)) == pytest.approx(scale, abs=0.02)
