"""Friction that depends on the direction of sliding (`bridge/sim/anisotropy.py`, the `anisotropic_friction`
effect): the added force in closed form, the footprint's quadrature, and real Drake pushes of the proof's block."""
import math

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.diagnosis.effects import Evidence, get_effect  # noqa: E402
from bridge.errors import SceneError  # noqa: E402
from bridge.params.model import Setting, apply_model  # noqa: E402
from bridge.rollout.rollout import run_rollout  # noqa: E402
from bridge.sim.anisotropy import AnisotropicFriction, FrictionField, footprint_points, slip_force  # noqa: E402
from bridge.sim.support import gyration_radius  # noqa: E402

MU = 0.25


def matrix(a_c, a_s, mu=MU):
    return mu * np.array([[1 + a_c, a_s], [a_s, 1 - a_c]])


def test_the_added_force_is_the_ellipse_less_drakes_isotropic_friction():
    load = np.array([2.0, 2.0, 2.0])
    v = np.array([[0.1, 0.0], [0.0, 0.1], [0.0, 0.0]])  # along the grain, across it, at rest
    f = slip_force(matrix(0.4, 0.0), MU, load, v, slip_speed=1e-9)
    np.testing.assert_allclose(f[0], [-2.0 * MU * 0.4, 0.0], atol=1e-9)  # mu (1 + a) - mu, against the motion
    np.testing.assert_allclose(f[1], [0.0, 2.0 * MU * 0.4], atol=1e-9)  # mu (1 - a) - mu: less friction across
    np.testing.assert_allclose(f[2], [0.0, 0.0], atol=1e-12)  # nothing at rest
    np.testing.assert_allclose(slip_force(matrix(0.0, 0.0), MU, load, v), 0.0, atol=1e-12)  # isotropic: nothing
    # sliding at 45 deg to the grain the elliptic force is not anti-parallel: it pushes towards the slippery axis
    diag = slip_force(matrix(0.4, 0.0), MU, load[:1], np.array([[0.1, 0.1]]), slip_speed=1e-9)[0]
    total = diag - 2.0 * MU * np.array([0.1, 0.1]) / math.hypot(0.1, 0.1)
    assert total[0] < total[1] < 0  # more resistance along x than along y


def test_the_footprint_quadrature_keeps_area_centroid_and_gyration():
    square = np.array([(-0.04, -0.02), (0.06, -0.02), (0.06, 0.03), (-0.04, 0.03)])
    points, weights = footprint_points(square)
    assert weights.sum() == pytest.approx(1.0) and len(points) == 4 * 16
    np.testing.assert_allclose(weights @ points, [0.01, 0.005], atol=1e-12)
    r2 = weights @ np.sum((points - [0.01, 0.005]) ** 2, axis=1)
    assert math.sqrt(r2) == pytest.approx(gyration_radius(square), rel=0.02)


@pytest.fixture(scope="module")
def push(block_pushes):
    """A push of the block nearly along +x."""
    return block_pushes[1]


@pytest.fixture(scope="module")
def end(block_track):
    def displacement(rollout, odb):
        track = block_track(rollout)
        return track[-1, :3] - track[0, :3]

    return displacement


def test_a_grain_along_the_push_turns_it_towards_the_slippery_side(push, odb, end):
    iso = end(push, odb)
    along = end(apply_model((Setting("aniso_c", "block", 0.4),), push, odb), odb)
    across = end(apply_model((Setting("aniso_c", "block", -0.4),), push, odb), odb)
    assert abs(iso[1]) < 0.015 and iso[0] > 0.07  # isotropic: nearly straight along x
    # more friction along x: the block swerves sideways (the way it was already drifting) and travels less in x
    assert np.sign(along[1]) == np.sign(iso[1]) and abs(along[1]) > abs(iso[1]) + 0.015 and along[0] < iso[0] - 0.01
    # more friction across: it runs straighter than isotropic
    assert abs(across[1]) < abs(iso[1])
    assert abs(along[2]) < 1e-4  # it stays on the surface


def test_the_kinds_add_the_force_off_isotropy_only(push, odb):
    out = apply_model((Setting("aniso_c", "block", 0.3), Setting("aniso_s", "block", -0.2),
                       Setting("friction", "surface", 0.5)), push, odb)
    (extra,) = out.extras
    assert isinstance(extra, AnisotropicFriction) and extra.mu == pytest.approx(2 * 0.5 * 0.25 / 0.75)
    assert extra.angle == pytest.approx(0.5 * math.atan2(-0.2, 0.3))
    assert apply_model((Setting("aniso_c", "block", 0.0),), push, odb).extras == ()


def test_bad_anisotropy_names_the_object(push, odb):
    with pytest.raises(SceneError, match="needs .a. < 0.9"):
        run_rollout(push.with_extras(AnisotropicFriction("block", 0.8, 0.6, MU, 0.0)), odb)
    with pytest.raises(SceneError, match="no free object 'surface'"):
        run_rollout(push.with_extras(AnisotropicFriction("surface", 0.1, 0.0, MU, 0.0)), odb)


def test_a_bad_friction_field_names_the_object(push, odb):
    with pytest.raises(SceneError, match="friction field on 'block': needs finite values and a positive coefficient"):
        run_rollout(push.with_extras(FrictionField("block", float("nan"), 0.0, (0.0, 0.0), MU, 0.0)), odb)
    with pytest.raises(SceneError, match="friction field: no free object 'surface'"):
        run_rollout(push.with_extras(FrictionField("surface", 1.0, 0.0, (0.0, 0.0), MU, 0.0)), odb)


def test_the_seed_points_along_the_grain_the_residuals_suggest(push, odb):
    """Across-push residuals k sin 2 (phi - theta) from pushes in several directions give the seed's grain theta;
    the signature prefers two turns per push direction (a grain) to one (a tilt)."""
    effect = get_effect("anisotropic_friction")
    theta = math.radians(25)
    phis = np.radians([-60, -25, 0, 20, 50, 80])

    def evidence(across):
        return Evidence(tuple({"direction": (math.cos(p), math.sin(p)), "final_across": a, "significant": True}
                              for p, a in zip(phis, across)), push.world, odb)

    grain = evidence(8.0 * np.sin(2 * (phis - theta)))
    tilt = evidence(8.0 * np.sin(phis - theta))
    seed = effect.seeds(grain, "block")[1]
    angle = 0.5 * math.atan2(seed["aniso_s[block]"], seed["aniso_c[block]"])
    assert angle == pytest.approx(theta, abs=1e-6)
    assert effect.signature(grain, "block") > 0.5 > effect.signature(tilt, "block")


def _slide(world, odb, extras=(), speed=0.3, settle=0.2, longest=3.0) -> float:
    """How far (m) the block slides when, resting on the surface with the robot taken away, it is set moving
    along +x at `speed`: v^2 / (2 mu g) for a coefficient mu that does not change with the slip speed."""
    from dataclasses import replace

    from pydrake.multibody.math import SpatialVelocity
    from pydrake.systems.analysis import Simulator

    from bridge.sim.scene import build_scene

    world = replace(world, robot=None)
    scene = build_scene(world, odb, extras=extras)
    context = scene.new_context(world)
    plant, body = scene.plant, scene.bodies["block"]
    plant_ctx = plant.GetMyMutableContextFromRoot(context)
    simulator = Simulator(scene.diagram, context)
    simulator.Initialize()
    simulator.AdvanceTo(settle)
    start = plant.EvalBodyPoseInWorld(plant_ctx, body).translation()
    plant.SetFreeBodySpatialVelocity(plant_ctx, body, SpatialVelocity(np.zeros(3), np.array([speed, 0.0, 0.0])))
    simulator.AdvanceTo(settle + longest)
    assert np.linalg.norm(plant.EvalBodySpatialVelocityInWorld(plant_ctx, body).translational()) < 1e-3
    return float(plant.EvalBodyPoseInWorld(plant_ctx, body).translation()[0] - start[0])


def test_friction_that_falls_with_the_slip_speed_holds_a_slow_slide_back_and_spares_a_fast_one(push, odb):
    """The Stribeck curve through the real Drake simulation: a block slid at 0.3 m/s (18.0 mm to rest, v^2 / (2 mu
    g) = 18.3 mm) on a coefficient that is twice Drake's near rest (rate_drop 1) stops within 0.54 of that where
    the curve falls only above the slide's speed (rate_speed 1 m/s: the coefficient 1.7-2 times Drake's
    throughout), and as far as without it where the curve has fallen within the last millimetres (10 mm/s:
    0.999)."""
    plain = _slide(push.world, odb)
    mu = apply_model((Setting("rate_drop", "block", 1.0),), push, odb).extras[0].mu
    assert plain == pytest.approx(0.3 ** 2 / (2 * mu * 9.81), rel=0.15)  # v^2 / (2 mu g)

    def rate(speed):
        return _slide(push.world, odb, apply_model((Setting("rate_drop", "block", 1.0),
                                                    Setting("rate_speed", "block", speed)), push, odb).extras)
    slow_curve, fast_curve = rate(1.0), rate(0.01)
    assert 0.45 * plain < slow_curve < 0.65 * plain  # a coefficient 1.7-2 times Drake's over the slide
    assert 0.97 * plain < fast_curve < plain  # the excess only below a few times 10 mm/s


def test_the_rate_kinds_add_the_force_off_a_flat_curve_only(push, odb):
    from bridge.sim.anisotropy import RateFriction

    out = apply_model((Setting("rate_drop", "block", 0.8), Setting("rate_speed", "block", 0.05),
                       Setting("friction", "surface", 0.5)), push, odb)
    (extra,) = out.extras
    assert isinstance(extra, RateFriction) and (extra.drop, extra.speed) == (0.8, 0.05)
    assert extra.mu == pytest.approx(2 * 0.5 * 0.25 / 0.75)  # the pair's coefficient, as Drake combines it
    np.testing.assert_allclose(extra.factor(np.zeros((3, 2)), np.array([0.0, 0.05, 10.0])),
                               [1.8, 1 + 0.8 / math.e, 1.0])
    assert apply_model((Setting("rate_drop", "block", 0.0),), push, odb).extras == ()
    with pytest.raises(SceneError, match="rate-dependent friction on 'block': needs drop > -0.9, a positive speed"):
        run_rollout(push.with_extras(RateFriction("block", 1.0, 0.0, MU, 0.0)), odb)
