"""The latency the contact gaps measure (loader.ContactFit): recordings pushed at different speeds tell a rod that
runs ahead of or behind the real one from an offset or an outline error, before any simulation; the latency
effect starts there and a fitted latency the gaps rule out is refused."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.diagnosis.effects import Evidence, get_effect
from bridge.diagnosis.identify import Scored, _checked_against, _measured
from bridge.diagnosis.loader import LoaderEvidence, StartReading
from bridge.odb import load_object_database
from bridge.recording.adjustments import StartClearance
from bridge.values import Pose
from bridge.world import ObjectState, RobotState, WorldState

SPEEDS = (0.01, 0.02, 0.05, 0.075, 0.1, 0.02, 0.05, 0.1)  # m/s into the object while it pushed
SCATTER = 2e-4  # m: the gap's scatter within a push (motion capture, outline)


def _loader(gaps, speeds=SPEEDS) -> LoaderEvidence:
    rng = np.random.default_rng(3)
    readings = []
    for k, (gap, u) in enumerate(zip(gaps, speeds)):
        a = 2 * math.pi * k / len(gaps) + 0.3
        start = StartClearance("box", 0.002, (1.0, 0.0), (0.0, 0.0), 1e-4, 0.05, SCATTER,
                               contact_gap=float(gap + rng.normal(0.0, SCATTER / 3)),
                               contact_normal=(math.cos(a), math.sin(a)), contact_speed=u)
        readings.append(StartReading(f"r{k}", start, 1e-3))
    return LoaderEvidence((), tuple(readings))


def _normals(n):
    return [(math.cos(2 * math.pi * k / n + 0.3), math.sin(2 * math.pi * k / n + 0.3)) for k in range(n)]


def test_a_latency_shows_as_gaps_that_grow_with_speed_and_is_measured():
    tau = 0.06
    fit = _loader([-tau * u for u in SPEEDS]).contact_fit()
    assert fit.latency_evident and fit.latency == pytest.approx(tau, abs=0.005)
    assert not fit.offset_evident and not fit.inflation_evident  # the latency explains the gaps, nothing else


def test_an_offset_and_an_outline_error_are_not_read_as_latency():
    D, s = np.array([0.003, -0.002]), 0.0008
    gaps = [-np.dot(n, D) + s for n in _normals(len(SPEEDS))]
    fit = _loader(gaps).contact_fit()
    assert not fit.latency_evident and abs(fit.latency) < 0.005
    assert fit.offset_evident and np.allclose(fit.offset, D, atol=3e-4)


def test_one_speed_cannot_tell_a_latency_from_an_outline_error():
    """Every recording pushed at 50 mm/s: a rod 3 mm inside on every side is a smaller object or a 60 ms lead; the
    gaps cannot say which, so no latency is evident."""
    fit = _loader([-0.003] * 8, speeds=(0.05,) * 8).contact_fit()
    assert not fit.latency_evident


def test_a_lead_that_moves_the_rod_less_than_half_a_millimetre_is_negligible():
    fit = _loader([-0.004 * u for u in SPEEDS]).contact_fit()  # 4 ms: 0.2 mm at the fastest push
    assert not fit.latency_evident


def _world():
    objects = {"box": ObjectState("box", "small_box", Pose((0.0, 0.0, 0.03)))}
    return WorldState(objects, robot=RobotState("pusher", "planar_pusher", Pose(), (("pusher_x", 0.0),
                                                                                   ("pusher_y", 0.0))))


def test_the_latency_effect_starts_at_the_measured_latency_held_at_it():
    odb = load_object_database()
    world = _world()
    loader = _loader([-0.06 * u for u in SPEEDS])
    fit = loader.contact_fit()
    measured = _measured(loader, world)
    assert measured["latency[pusher]"][0] == pytest.approx(fit.latency)
    effect = get_effect("latency")
    ev = Evidence((), world, odb, latency=fit.latency)
    assert effect.signature(ev, "pusher") == 1.0 > effect.signature(Evidence((), world, odb), "pusher")
    assert {"latency[pusher]": pytest.approx(fit.latency)} in effect.seeds(ev, "pusher")


def test_a_fitted_latency_the_gaps_rule_out_is_refused():
    """The gaps measure no latency (0 +- a few ms): a fit that puts 50 ms into the telemetry is soaking up a
    mismatch of the simulation; one within the gaps' uncertainty stands."""
    loader = _loader([0.0] * len(SPEEDS))

    def scored(value):
        return Scored("latency", "pusher", {"latency[pusher]": value}, {}, (), 1, 1.0, 1)

    assert "soaks up something else" in _checked_against(scored(0.05), loader).contradicted
    assert _checked_against(scored(0.001), loader).contradicted is None
