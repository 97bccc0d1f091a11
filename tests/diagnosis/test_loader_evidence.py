"""Never repair away evidence (issue 11, item 3): the loader's start-clearance shift of real MIT pushes, kept on the
trial, read by the diagnosis against a threshold from the recordings' own noise, and written to diagnosis.json and
the report."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bridge.diagnosis.effects import Evidence, get_effect
from bridge.diagnosis.identify import Identification, Scored
from bridge.diagnosis.loader import NOISE_SIGMAS, read_adjustments
from bridge.diagnosis.locate import Localisation
from bridge.diagnosis.report import diagnosis_json, report_markdown, validate
from bridge.diagnosis.runs import prepare
from bridge.odb import load_object_database
from bridge.recording.adjustments import StartClearance
from bridge.recording.mitpush import load_outline, load_push
from bridge.recording.mitsession import START_CLEARANCE, _start_clearance
from bridge.rollout.compare import PoseError
from bridge.rollout.trials import _push_trial

RECT1 = ("motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.800_t=-0.349.h5",  # the rod starts 1.6 mm away
         "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.800_t=1.396.h5")  # 0.25 mm inside the outline
PLANTED = 0.006  # m: how deep the planted calibration offset puts the rod inside the object at t = 0


@pytest.fixture(scope="module")
def mit_odb(mit_push_root):
    return load_object_database(datasets={"mit-push": mit_push_root})


def _planted(push, outline, depth: float = PLANTED):
    """The push as recorded by a pusher whose calibration is off by a constant world offset that starts the rod
    `depth` inside the object (along the outline's inward normal at t = 0)."""
    clearance, normal = _start_clearance(push, outline, 0.0)
    offset = -(clearance + depth) * normal
    return replace(push, tip_xy=push.tip_xy + offset), normal


def _trial(push, odb):
    """The push as `bridge diagnose` loads it (rect1's mesh frame is its pose frame; motion capture at 250 Hz)."""
    return _push_trial(push, odb, 0.0, 250.0)


def test_a_rod_planted_6_mm_inside_keeps_the_shift_on_the_trial(mit_push_root, mit_odb):
    push = load_push(mit_push_root / "train" / RECT1[0])
    planted, normal = _planted(push, load_outline("rect1", mit_push_root))
    trial = _trial(planted, mit_odb)
    start = next(a for a in trial.adjustments if isinstance(a, StartClearance))
    assert start.penetration == pytest.approx(PLANTED, abs=1e-6) and start.moved
    np.testing.assert_allclose(start.shift, (PLANTED + START_CLEARANCE) * normal, atol=1e-9)  # along the normal
    np.testing.assert_allclose(trial.telemetry.positions[0] - planted.tip_xy[0], start.shift, atol=1e-12)
    assert start.contact_spread is not None and start.contact_spread < 1e-3 and start.lever > 0.03
    assert any("6.00 mm inside the outline" in n for n in trial.notes)


def test_normal_pushes_do_not_read_as_started_inside(mit_push_root, mit_odb):
    prepared = [prepare(_trial(load_push(mit_push_root / "train" / name), mit_odb), mit_odb) for name in RECT1]
    loader = read_adjustments(prepared)
    assert len(loader.readings) == 2 and not loader.inside and loader.sentence() is None
    inside = loader.readings[1]  # the loader still moves it 0.25 mm out, and keeps that
    assert inside.start.moved and 0.0002 < inside.start.penetration < inside.threshold
    assert loader.offset_estimate() is None
    ev = Evidence((), prepared[0].world, mit_odb, started_inside=0.0, loader_offset=loader.offset_estimate())
    assert len(get_effect("pusher_offset").seeds(ev, "pusher")) == 1  # the null offset only


def test_diagnosis_json_and_report_carry_the_adjustments_and_the_evidence(mit_push_root, mit_odb):
    outline = load_outline("rect1", mit_push_root)
    planted, normal = _planted(load_push(mit_push_root / "train" / RECT1[0]), outline)
    prepared = [prepare(_trial(planted, mit_odb), mit_odb),
                prepare(_trial(load_push(mit_push_root / "train" / RECT1[1]), mit_odb), mit_odb)]
    loader = read_adjustments(prepared, held_out=[1])
    assert [r.recording for r in loader.inside] == [prepared[0].name]
    threshold = loader.inside[0].threshold
    assert 0.0 < threshold < 0.002  # a few noise sigmas: far below the planted 6 mm
    sentence = loader.sentence()
    assert sentence.startswith("the rod started 6.0 mm inside the object in 1 of 2 recordings")
    assert "evidence of a pusher calibration offset or a wrong object model" in sentence
    assert f"({NOISE_SIGMAS:g} sigma" in sentence
    estimate = loader.offset_estimate()
    np.testing.assert_allclose([estimate["pusher_x"], estimate["pusher_y"]], PLANTED * normal, atol=1e-6)

    error = PoseError(0.001, 0.01, 0.002, 100)
    none = Scored("none", "world", {}, {}, (), 0, 100.0, 100, error=error, held_out_chi2=100.0, held_out_n=100,
                  held_out_error=error)
    ident = Identification("none", (none,), Localisation(()), (prepared[0].name,), (prepared[1].name,), 1.0, (),
                           (sentence,), 0, 0.0, loader=loader)
    data = diagnosis_json(ident)
    validate(data)
    by = {e["recording"]: e for e in data["adjustments"]}
    start = next(a for a in by[prepared[0].name]["adjustments"] if a["kind"] == "start_clearance")
    assert start["inside"] and start["penetration_m"] == pytest.approx(PLANTED, abs=1e-5)
    assert math.hypot(*start["shift_m"]) == pytest.approx(PLANTED + START_CLEARANCE, abs=1e-5)
    assert by[prepared[1].name]["held_out"] and data["evidence"]["start_inside"]["count"] == 1
    assert data["evidence"]["start_inside"]["sentence"] == sentence
    markdown = report_markdown(ident, data, [])
    assert "## What the loader changed" in markdown and "6.00 mm inside" in markdown and sentence in markdown

    # the pusher_offset effect starts its search at the offset the penetration implies, and is favoured
    ev = Evidence((), prepared[0].world, mit_odb, started_inside=len(loader.inside) / len(loader.readings),
                  loader_offset=estimate)
    effect = get_effect("pusher_offset")
    seeds = effect.seeds(ev, "pusher")
    assert seeds[1] == pytest.approx({"joint_offset[pusher_x]": estimate["pusher_x"],
                                      "joint_offset[pusher_y]": estimate["pusher_y"]})
    assert effect.signature(ev, "pusher") > effect.signature(replace(ev, started_inside=0.0), "pusher")


def test_a_rod_offset_replaces_the_loaders_repair_so_it_means_the_same_rod_in_every_recording(mit_push_root, mit_odb):
    """A fitted offset is relative to the raw recording: in a recording the loader moved out of the object the
    offset replaces that shift (true = raw + D), in one it did not it is added as it is; no offset (0) keeps the
    loader's repair."""
    from bridge.params import Setting, trial_rollout

    push = load_push(mit_push_root / "train" / RECT1[0])
    planted, _ = _planted(push, load_outline("rect1", mit_push_root))
    moved, kept = _trial(planted, mit_odb), _trial(push, mit_odb)
    D = {"pusher_x": 0.004, "pusher_y": -0.003}
    model = tuple(Setting("joint_offset", j, v) for j, v in D.items())
    for trial, raw in ((moved, planted.tip_xy[0]), (kept, push.tip_xy[0])):
        tip = trial_rollout(trial, model, mit_odb).telemetry.positions[0]
        np.testing.assert_allclose(tip, raw + np.array([D["pusher_x"], D["pusher_y"]]), atol=1e-12)
    repaired = trial_rollout(moved, (Setting("joint_offset", "pusher_x", 0.0),), mit_odb).telemetry.positions[0]
    np.testing.assert_allclose(repaired, moved.telemetry.positions[0], atol=1e-12)


def test_the_contact_gaps_of_real_pushes_recover_a_planted_offset_and_an_outline_error(mit_push_root, mit_odb):
    """While the rod pushes, its gap to the outline should be zero: a calibration offset D moves it by -n.D
    (n the outline's normal there, differing by side pushed), an outline too small moves every gap alike. Both
    are recovered from the gaps alone, before any simulation, relative to what the unplanted pushes give."""
    names = sorted(p.name for p in (mit_push_root / "train").glob("*shape=rect1_*.h5"))
    pushes = [load_push(mit_push_root / "train" / n) for n in names]

    def fit(offset=(0.0, 0.0), grow=0.0):
        trials = [_trial(replace(p, tip_xy=p.tip_xy - np.array(offset)), mit_odb) for p in pushes]
        if grow:  # the real object larger than the outline: every recorded rod `grow` further from the centre
            trials = []
            for p in pushes:
                rel = p.tip_xy - p.object_pose[:, :2]
                away = rel / np.linalg.norm(rel, axis=1, keepdims=True)
                trials.append(_trial(replace(p, tip_xy=p.tip_xy + grow * away), mit_odb))
        return read_adjustments([prepare(t, mit_odb, 25.0) for t in trials]).contact_fit()

    base = fit()
    planted = fit(offset=(0.004, -0.003))  # the real rod at recorded + (4, -3) mm
    assert planted.offset_evident and not base.offset_evident or planted.offset_sigmas() > base.offset_sigmas()
    np.testing.assert_allclose(np.array(planted.offset) - np.array(base.offset), (0.004, -0.003), atol=4e-4)
    assert abs(planted.inflation - base.inflation) < 4e-4
    grown = fit(grow=0.002)
    assert grown.inflation - base.inflation == pytest.approx(0.002, abs=6e-4)
    assert np.linalg.norm(np.array(grown.offset) - np.array(base.offset)) < 1e-3
    assert grown.rms_after < 0.5 * grown.rms_before  # what is left once D and s are removed: the scatter


def test_the_measured_offset_is_the_calibration_the_forks_are_measured_at(mit_push_root, mit_odb):
    """`identify.measured_model`: the rod offset the gaps make evident, as the model the diagnosis measures its
    forks at (where the rod is known to be), planted on top of the real pushes' own."""
    from bridge.diagnosis.identify import measured_model
    from bridge.diagnosis.runs import Runner
    from bridge.rollout import make_executor

    names = sorted(p.name for p in (mit_push_root / "train").glob("*shape=rect1_*.h5"))
    pushes = [load_push(mit_push_root / "train" / n) for n in names]

    def model(offset):
        trials = [_trial(replace(p, tip_xy=p.tip_xy - np.array(offset)), mit_odb) for p in pushes]
        runner = Runner([prepare(t, mit_odb, 25.0) for t in trials], mit_odb, make_executor("serial", mit_odb))
        train, held = range(len(trials) - 2), range(len(trials) - 2, len(trials))
        return {s.name: s.value for s in measured_model(runner, train, held)}

    base, planted = model((0.0, 0.0)), model((0.004, -0.003))
    assert set(planted) == {"joint_offset[pusher_x]", "joint_offset[pusher_y]"}
    shift = np.array([planted[k] - base.get(k, 0.0) for k in sorted(planted)])
    np.testing.assert_allclose(shift, (0.004, -0.003), atol=1e-3)
    assert not any(k.startswith("latency") for k in planted)  # an offset is not read as a lead


def test_the_contact_gap_is_read_where_the_rod_touches_not_where_a_kicked_object_slides_ahead(mit_push_root,
                                                                                                mit_odb):
    """A push that kicks the object ahead of the rod moves it while nothing touches: those samples (no force) put
    the rod millimetres behind the outline and would read as a calibration offset. The force says where it
    touches; the gap is read there."""
    from bridge.recording.mitsession import _contact_gap

    push = load_push(mit_push_root / "train" / "motion_surface=abs_shape=hex_a=0_v=100_i=1.000_s=0.600_t=0.000.h5")
    outline = load_outline("hex", mit_push_root)
    yaw = -math.pi / 2  # hex's pose frame is turned a quarter from its mesh (`estimate_frame_yaw`)
    gap, *_ = _contact_gap(push, outline, yaw)
    # the object slides 3 mm ahead of the rod, free of it, in two of every three moving samples
    speed = np.linalg.norm(np.gradient(push.object_pose[:, :2], push.t, axis=0), axis=1)
    moving = np.nonzero(speed > 0.3 * np.percentile(speed, 90))[0]
    kicked = moving[(np.arange(len(moving)) % 3) != 0]
    pose = np.array(push.object_pose)
    step = np.gradient(pose[:, :2], axis=0)
    pose[kicked, :2] += 0.003 * step[kicked] / np.linalg.norm(step[kicked], axis=1, keepdims=True)
    wrench = np.array(push.wrench)
    wrench[kicked] = 0.0
    slid = replace(push, object_pose=pose, wrench=wrench)
    touched, *_ = _contact_gap(slid, outline, yaw)
    blind, *_ = _contact_gap(replace(slid, wrench=None), outline, yaw)  # no force to tell: every moving sample
    assert abs(touched - gap) < 3e-4, (touched, gap)
    assert blind - gap > 1e-3, (blind, gap)


def test_the_contact_gaps_of_real_pushes_at_different_speeds_measure_a_planted_latency(mit_push_root, mit_odb):
    """A recorded rod that runs tau ahead of the real one (the `latency` kind: true(t) = recorded(t - tau)) sits
    tau x its speed inside the outline while it pushes: the rect1 pushes, at 10-150 mm/s, measure tau from the
    gaps alone, before any simulation; the unplanted pushes show no latency that matters, and a planted
    calibration offset reads as an offset, not as a latency."""
    names = sorted(p.name for p in (mit_push_root / "train").glob("*shape=rect1_*.h5"))
    pushes = [load_push(mit_push_root / "train" / n) for n in names]

    def fit(tau=0.0, offset=(0.0, 0.0)):
        moved = []
        for p in pushes:
            ahead = np.column_stack([np.interp(p.t + tau, p.t, p.tip_xy[:, k]) for k in range(2)])
            moved.append(_trial(replace(p, tip_xy=ahead - np.array(offset)), mit_odb))
        return read_adjustments([prepare(t, mit_odb, 25.0) for t in moved]).contact_fit()

    base, planted, offset = fit(), fit(tau=0.06), fit(offset=(0.003, 0.002))
    assert not base.latency_evident and abs(base.latency) * base.speed < 5e-4
    assert planted.latency_evident
    assert planted.latency - base.latency == pytest.approx(0.06, abs=0.01)
    assert not offset.latency_evident and offset.offset_evident
    assert abs(offset.latency - base.latency) < 2 * offset.latency_sd  # within its own uncertainty
    sentences = read_adjustments([prepare(_trial(replace(p, tip_xy=np.column_stack(
        [np.interp(p.t + 0.06, p.t, p.tip_xy[:, k]) for k in range(2)])), mit_odb), mit_odb, 25.0)
        for p in pushes]).sentences()
    assert any("evidence of latency" in s and "ahead of the real rod" in s for s in sentences)
