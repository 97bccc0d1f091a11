"""The limit-surface baseline of quasi-static pushing: its geometry, the motion cone, and real MIT pushes."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.errors import LimitSurfaceError
from bridge.recording.mitpush import PUSHER_RADIUS
from bridge.rollout.limit_surface import (fit_pusher_friction, limit_surface_of, push_object,
                                          push_residuals, push_trial, pushed_object, surface_friction_from_force)

SIDE = 0.09  # m, rect1
SQUARE = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float) * SIDE / 2


def disk(radius: float, k: int = 2000, centre=(0.0, 0.0)) -> np.ndarray:
    phi = np.linspace(0.0, 2 * math.pi, k, endpoint=False)
    return np.column_stack([centre[0] + radius * np.cos(phi), centre[1] + radius * np.sin(phi)])


def straight_push(start_xy, direction, length: float, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """A rod path at 50 mm/s from `start_xy` along `direction` for `length` m."""
    u = np.asarray(direction, float) / np.linalg.norm(direction)
    s = np.linspace(0.0, length, n)
    return s / 0.05, np.asarray(start_xy, float) + s[:, None] * u


def local_rod(push, tip, b: int = 0) -> np.ndarray:
    """The rod's centre in the object's frame at every sample."""
    pose = push.poses[b]
    rel = tip - pose[:, :2]
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    return np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]])


# --- the limit surface ----------------------------------------------------------------------------------------
def test_c_of_a_disk_is_two_thirds_of_its_radius():
    """(1/A) integral |r| dA = (1 / pi R^2) integral_0^R r 2 pi r dr = 2R/3, wherever the disk lies."""
    radius = 0.0524
    for centre in ((0.0, 0.0), (0.03, -0.01)):
        surface = limit_surface_of(disk(radius, centre=centre))
        assert surface.c == pytest.approx(2 * radius / 3, rel=1e-5)
        assert surface.centre == pytest.approx(centre, abs=1e-12)


def test_c_of_a_square_and_either_winding():
    """A square of side a: the mean distance from its centre is a (sqrt 2 + asinh 1) / 6."""
    expected = SIDE * (math.sqrt(2) + math.asinh(1.0)) / 6
    assert limit_surface_of(SQUARE).c == pytest.approx(expected, rel=1e-12)
    assert limit_surface_of(SQUARE[::-1]).c == pytest.approx(expected, rel=1e-12)
    long = limit_surface_of(SQUARE * [2.0, 0.5])  # same area, farther from the centre
    assert long.area == pytest.approx(SIDE ** 2) and long.c > expected


@pytest.mark.parametrize("outline, match", [
    (np.zeros((2, 2)), "K x 2 vertices with K >= 3"),
    (np.array([[0, 0], [1, 0], [2, 0]], float), "encloses no area"),
    (np.array([[0, 0], [1, 0], [np.nan, 1]]), "non-finite"),
])
def test_a_bad_outline_is_one_clear_error(outline, match):
    with pytest.raises(LimitSurfaceError, match=f"outline: .*{match}"):
        limit_surface_of(outline)


def test_bad_pusher_paths_and_friction_are_named():
    surface = limit_surface_of(SQUARE)
    times, tip = straight_push((-0.06, 0.0), (1, 0), 0.03)
    with pytest.raises(LimitSurfaceError, match="mu_p: .*>= 0"):
        push_object(surface, times, tip, (0, 0, 0), mu_p=-0.1)
    with pytest.raises(LimitSurfaceError, match="tip: .*increasing times"):
        push_object(surface, times[::-1], tip, (0, 0, 0), mu_p=0.3)
    with pytest.raises(LimitSurfaceError, match="tip: .*N x 2"):
        push_object(surface, times, tip[:, :1], (0, 0, 0), mu_p=0.3)
    with pytest.raises(LimitSurfaceError, match="start: "):
        push_object(surface, times, tip, (0, 0), mu_p=0.3)


# --- pushes -------------------------------------------------------------------------------------------------------
def test_no_motion_without_contact():
    surface = limit_surface_of(SQUARE)
    times, tip = straight_push((-0.08, SIDE / 2 + PUSHER_RADIUS + 0.002), (1, 0), 0.16)  # grazes past the top
    push = push_object(surface, times, tip, (0.0, 0.0, 0.0), mu_p=0.5)
    assert not push.contact.any()
    assert np.all(push.poses == 0.0)


def test_a_centred_push_translates_without_turning():
    surface = limit_surface_of(SQUARE)
    gap = 0.01
    times, tip = straight_push((-SIDE / 2 - PUSHER_RADIUS - gap, 0.0), (1, 0), 0.06)
    push = push_object(surface, times, tip, (0.0, 0.0, 0.0), mu_p=[0.1, 0.5])
    final = push.poses[:, -1]
    assert final[:, 0] == pytest.approx(0.06 - gap, abs=2e-4)  # moved as far as the rod went after touching
    assert np.abs(final[:, 1:]).max() < 1e-12
    assert not push.sliding.any() and push.contact[:, -1].all()


@pytest.mark.parametrize("offset, turn", [(0.02, -1.0), (-0.02, 1.0)])
def test_an_off_centre_push_turns_away_from_the_rod(offset, turn):
    """Pushing +x above the centre turns the object clockwise (negative yaw), below it counter-clockwise."""
    surface = limit_surface_of(SQUARE)
    times, tip = straight_push((-SIDE / 2 - PUSHER_RADIUS - 0.002, offset), (1, 0), 0.05)
    push = push_object(surface, times, tip, (0.0, 0.0, 0.0), mu_p=0.3)
    yaw = push.poses[0, -1, 2]
    assert np.sign(yaw) == turn and abs(yaw) > math.radians(5)
    assert push.poses[0, -1, 0] > 0.02
    gaps = np.abs(local_rod(push, tip)[push.contact[0]][:, 0] + SIDE / 2 + PUSHER_RADIUS)
    assert gaps.max() < 1e-4  # the rod stays on the side it pushes, it does not sink in


def test_a_push_outside_the_motion_cone_slides_along_the_side():
    """At the side's centre the motion cone's half-angle is atan(mu_p (1 + a^2 / 4c^2)): 28 deg for mu_p = 0.2,
    65 deg for 0.8. A push 50 deg off the normal slides at once with the first; with the second it sticks while
    the square turns away, until the push is the cone's half-angle off the turned side's normal."""
    surface = limit_surface_of(SQUARE)
    half_angle = [math.degrees(math.atan(mu * (1 + SIDE ** 2 / (4 * surface.c ** 2)))) for mu in (0.2, 0.8)]
    assert half_angle[0] < 50 < half_angle[1]
    angle = math.radians(50)
    start = (-SIDE / 2 - PUSHER_RADIUS, 0.0)
    times, tip = straight_push(start, (math.cos(angle), math.sin(angle)), 0.03)
    push = push_object(surface, times, tip, (0.0, 0.0, 0.0), mu_p=[0.2, 0.8])
    touching = push.contact[0]
    assert push.sliding[0, touching].mean() > 0.9
    along = local_rod(push, tip, 0)[touching][:, 1]
    assert np.ptp(along) > 0.005  # slid more than 5 mm along the side
    onset = int(np.argmax(push.sliding[1]))
    assert onset > 0.5 * len(times)
    turned = -push.poses[1, onset, 2]
    assert 50 + math.degrees(turned) == pytest.approx(half_angle[1], abs=1.0)
    # stuck: the rod's centre moves along the side only as the contact rolls round the rod as the square turns
    rolled = np.ptp(local_rod(push, tip, 1)[1:onset, 1])
    assert rolled == pytest.approx(PUSHER_RADIUS * turned, rel=0.02)


# --- real MIT pushes ----------------------------------------------------------------------------------------------
REAL = ("motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.800_t=0.000.h5",
        "motion_surface=abs_shape=ellip1_a=0_v=50_i=0.000_s=0.175_t=-0.349.h5",
        "motion_surface=abs_shape=hex_a=0_v=50_i=4.000_s=0.700_t=0.349.h5")


@pytest.fixture(scope="module")
def real_trials(mit_push_root, odb):
    from bridge.rollout import load_trials

    files = [mit_push_root / "train" / name for name in REAL]
    missing = [f.name for f in files if not f.is_file()]
    if missing:
        pytest.skip(f"MIT pushing files not in {mit_push_root / 'train'}: {', '.join(missing)}")
    return load_trials(files, odb)


def test_real_pushes_are_predicted_to_millimetres(real_trials, odb):
    """The literature reports the limit-surface model a few millimetres and degrees off on these pushes of
    ~30 mm; here: finite, within 15 mm / 15 deg at the end, and far better than predicting no motion."""
    from bridge.rollout.compare import error_of_residuals

    for trial in real_trials:
        pushed = pushed_object(trial, odb)
        push = push_trial(trial, pushed, 0.25)
        rows = push_residuals(trial, pushed, push)[0]
        error = error_of_residuals(rows)
        final = np.concatenate(rows)[-1]
        assert np.isfinite(error.e) and push.contact[0].any(), trial.name
        assert np.linalg.norm(final[:3]) < 0.015 and np.linalg.norm(final[3:]) < math.radians(15), trial.name
        still = push.poses.copy()
        still[:] = still[:, :1]
        resting = error_of_residuals(push_residuals(trial, pushed, type(push)(
            push.times, still, push.contact, push.sliding, push.load, push.mu_p))[0])
        assert error.e_t < 0.5 * resting.e_t, trial.name
        mu_s = surface_friction_from_force(trial, pushed, push)
        assert mu_s is None if trial.force is None else 0.05 < mu_s < 1.5, trial.name


def test_fitting_the_pusher_friction_does_not_worsen_the_error(real_trials, odb):
    pushed = [pushed_object(t, odb) for t in real_trials]
    fit = fit_pusher_friction(real_trials, pushed, 0.25, max_evaluations=12)
    assert fit.after.e <= fit.before.e + 1e-12
    assert 0.01 <= fit.mu_p <= 1.5 and fit.c_scale == 1.0 and fit.evaluations < 60
    with_pressure = fit_pusher_friction(real_trials, pushed, 0.25, fit_pressure=True, max_evaluations=12)
    assert with_pressure.after.e <= with_pressure.before.e + 1e-12 and 0.3 <= with_pressure.c_scale <= 1.5
