"""The recorded frame on an object, read from where the rod touched its outline while it pushed (no simulation):
found when the pushes pin it, never claimed when they cannot (one face pushed) or when there is none."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.diagnosis.outline import fit_frame

HALF = 0.045  # m: a 9 cm square
RADIUS = 0.00476  # m: the rod


def _pushes(frame, faces, rng, noise=2e-4, turn=0.3):
    """(rod xy, recorded xy, recorded yaw) of pushes on `faces` (outward normals in the body frame), the object
    turning by up to `turn` rad while the rod slides along the face; the recorder tracks `frame` = (x, y, d)."""
    x, y, d = frame
    out = []
    for k, normal in enumerate(faces):
        n = np.asarray(normal, dtype=float)
        t = np.array([-n[1], n[0]])
        s = np.linspace(-0.6, 0.6, 40) * HALF  # along the face
        local = (HALF + RADIUS) * n + s[:, None] * t  # the rod's centre, body frame
        yaw_b = 0.4 * k + np.linspace(0.0, turn, len(s))
        xy_b = np.column_stack([0.01 * np.arange(len(s)), 0.002 * k * np.ones(len(s))])
        c, sn = np.cos(yaw_b), np.sin(yaw_b)
        tip = xy_b + np.column_stack([c * local[:, 0] - sn * local[:, 1], sn * local[:, 0] + c * local[:, 1]])
        xy_r = xy_b + np.column_stack([c * x - sn * y, sn * x + c * y])
        out.append((tip + rng.normal(0.0, noise, tip.shape), xy_r, yaw_b + d))
    return out


SQUARE = np.array([[-HALF, -HALF], [HALF, -HALF], [HALF, HALF], [-HALF, HALF]])
SIDES = [(-1.0, 0.0), (0.0, -1.0), (1.0, 0.0), (-1.0, 0.0)]


def test_a_frame_off_the_centre_and_turned_is_read_from_the_pushes():
    rng = np.random.default_rng(3)
    truth = (0.004, -0.003, math.radians(4.0))
    fit = fit_frame(_pushes(truth, SIDES, rng), SQUARE)
    assert fit.evident, fit.to_json()
    assert (fit.x, fit.y) == pytest.approx(truth[:2], abs=3e-4)
    assert fit.yaw == pytest.approx(truth[2], abs=math.radians(0.5))
    assert fit.gap == pytest.approx(RADIUS, abs=3e-4)


def test_no_frame_is_claimed_where_there_is_none_or_the_pushes_cannot_pin_it():
    rng = np.random.default_rng(4)
    clean = fit_frame(_pushes((0.0, 0.0, 0.0), SIDES, rng), SQUARE)
    assert not clean.evident and math.hypot(clean.x, clean.y) < 3e-4, clean.to_json()
    # one face pushed, the object hardly turning: the offset along the face changes no gap
    one_face = fit_frame(_pushes((0.004, -0.003, 0.0), [(-1.0, 0.0)] * 3, rng, turn=0.0), SQUARE)
    assert not one_face.evident, one_face.to_json()


def test_a_fitted_frame_the_pushes_do_not_show_is_contradicted_where_they_pin_it():
    """A fit that moves the frame where the pushing samples put it at the centre soaks up something else (a
    mismatched world's leftovers): it takes the rod off the outline while it pushed. A frame that is there brings
    the rod onto the outline and stands; samples on one face cannot pin the offset along it and contradict
    nothing there."""
    from dataclasses import replace

    from bridge.diagnosis.identify import Scored, _frame_check

    rng = np.random.default_rng(5)
    seen = fit_frame(_pushes((0.0, 0.0, 0.0), SIDES, rng), SQUARE)

    def scored(x, y, yaw):
        return Scored("object_frame", "box", {"frame_x[box]": x, "frame_y[box]": y, "frame_yaw[box]": yaw}, {}, (),
                      3, 0.0, 1)

    why = _frame_check(scored(0.004, 0.0, 0.0), seen)
    assert why is not None and "+4.0" in why and "off the outline" in why and "soaks up" in why
    assert _frame_check(scored(0.0015, -0.001, math.radians(1.5)), seen) is not None  # 30 times the samples' scatter
    assert _frame_check(scored(0.0001, 0.0, 0.0), seen) is None
    assert _frame_check(scored(0.004, 0.0, 0.0), None) is None
    there = fit_frame(_pushes((0.004, -0.003, math.radians(4.0)), SIDES, rng), SQUARE)
    assert _frame_check(scored(0.004, -0.003, math.radians(4.0)), there) is None
    # one face pushed (its outward normal -x), the object not turning: an offset along the face (y) changes no gap,
    # and the samples' own fit wanders along it (here stopped by no bound; where a bound stops it, only the gaps judge)
    one_face = replace(fit_frame(_pushes((0.0, 0.0, 0.0), [(-1.0, 0.0)] * 3, rng, turn=0.0), SQUARE), at_bound=True)
    assert _frame_check(scored(0.0, 0.004, 0.0), one_face) is None
