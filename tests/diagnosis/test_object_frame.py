"""An error of the object model is an effect too: the recording tracks a frame on the object off (and turned from)
the one the model is built around. Without it, such recordings are out of reach of every physical parameter; with
it, the frame is fitted back through the real Drake simulation."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.diagnosis.effects import Evidence, get_effect
from bridge.diagnosis.identify import _friction_parameters
from bridge.diagnosis.runs import Runner, chi2_of, prepare
from bridge.diagnosis.search import Evaluator, fit
from bridge.errors import ParameterError
from bridge.params import ParameterSet, apply_model, check_values, parse_params
from bridge.prove.generate import generate_case
from bridge.prove.scenes import Case
from bridge.rollout import load_trials, make_executor
from bridge.rollout.rollout import Rollout
from bridge.sim.simulate import frame_track
from bridge.values import Pose


def test_the_body_starts_where_the_recorded_frame_puts_it_and_is_compared_in_that_frame(planar_world, odb):
    """The recorded start pose is the tracked frame's: the body starts at X_WR0 X_BR^-1, and its poses turned into
    the recorded frame give the recorded start back; the world model's frame (all null) changes nothing."""
    effect = get_effect("object_frame")
    x, y, yaw = 0.006, -0.004, 0.09
    model = effect.model(planar_world, odb, "block", {"frame_x[block]": x, "frame_y[block]": y,
                                                      "frame_yaw[block]": yaw})
    rollout = apply_model(model, Rollout(planar_world, None), odb)
    X_WR0 = planar_world.objects["block"].pose
    X_WB0 = rollout.world.objects["block"].pose
    (name, X_BR), = rollout.frames
    assert name == "block" and X_BR.xyz == pytest.approx((x, y, 0.0)) and X_BR.yaw() == pytest.approx(yaw)
    body = np.array([[*X_WB0.xyz, *X_WB0.quat]])
    recorded = frame_track(body, X_BR)[0]
    assert recorded[:3] == pytest.approx(X_WR0.xyz, abs=1e-12)
    assert Pose(tuple(recorded[:3]), tuple(recorded[3:])).rotation_to(X_WR0) == pytest.approx(0.0, abs=1e-9)
    assert X_WB0.translation_to(X_WR0) == pytest.approx(math.hypot(x, y))  # the body is elsewhere
    null = apply_model(effect.model(planar_world, odb, "block", {}), Rollout(planar_world, None), odb)
    assert null.frames == () and null.world.objects["block"].pose == X_WR0


def test_a_frame_outside_the_object_is_refused_with_its_reason(planar_world, odb):
    spec = parse_params({"params": [{"kind": "frame_x", "target": "block", "value": 0.5}]}, "frame.yaml")
    with pytest.raises(ParameterError) as err:
        check_values(spec, [Rollout(planar_world, None)], odb)
    text = str(err.value)
    assert "frame.yaml" in text and "params[0].value" in text and "outside 'block'" in text


@pytest.mark.slow
def test_recordings_of_another_frame_on_the_object_are_fitted_back(odb, tmp_path):
    """Recordings whose tracker follows a frame 6 mm off the block's centre and turned 4 deg (the proof's medium
    frame error, made by the recorder, not by the model): the ordinary parameters leave far more than the noise,
    the frame fitted with them does as well as the true values and finds the frame."""
    paths, truth = generate_case(Case("planar", "object_frame", "medium", 1), odb, tmp_path / "case", 3,
                                 force_noise=None)
    trials = load_trials(paths, odb)
    world = trials[0].world
    effect = get_effect("object_frame")
    with make_executor("serial", odb) as executor:
        runner = Runner([prepare(t, odb, 25.0) for t in trials], odb, executor)
        ev = Evaluator(runner, [0, 1, 2])
        friction = ParameterSet(tuple(_friction_parameters(world, odb, "block")))
        ordinary = fit(ev, friction, np.zeros(friction.dim), max_iterations=6)
        space = ParameterSet(tuple(_friction_parameters(world, odb, "block"))
                             + effect.parameters(world, odb, "block"))
        starts = [space.to_normal({**ordinary.values(), **seed}) for seed in effect.seeds(
            Evidence((), world, odb), "block")]  # as a diagnosis starts it: its seeds, with the fitted friction
        chis = [ev.chi2(space.model(space.from_normal(x))) for x in starts]
        # the turn is the weak direction (a 2 deg error costs 3 % of chi2): 8 evaluations left it 1.8 or 2.4 deg short
        # as round-off steered the secant steps (session 53); 16 bring it within 1 deg either way
        framed = fit(ev, space, starts[int(np.argmin(chis))], max_iterations=16)
        exact, n = chi2_of(runner.run(effect.model(world, odb, "block", truth.params), [0, 1, 2]))
    # the recorder's frame and the model's agree through the simulation (what is left: the noise, and the start
    # poses read from noisy observations)
    assert exact < 2.5 * n
    assert ordinary.chi2 > 5 * exact, "friction alone explains another frame: the test shows nothing"
    assert framed.chi2 < 1.1 * exact, (framed.values(), framed.chi2 / n, exact / n)
    found = {k: v for k, v in framed.values().items() if k.startswith("frame_")}
    recovery = effect.recovered(truth, found, (), world, odb)
    assert recovery.ok, recovery.text


def test_a_fit_compares_in_the_recorded_frame_too(odb):
    """`bridge fit`'s path (`fit.evaluate`, `rollout.compare`): a trial observed in a frame 5 mm off and turned
    3 deg (`synthesize_trial` through the same kinds) is matched exactly by that frame, and the world model, whose
    body starts where the recording's frame is, misses it by about the offset."""
    from bridge.fit.evaluate import evaluate
    from bridge.fit.synthetic import push_telemetries, push_world, synthesize_trial
    from bridge.params import Parameter
    from bridge.params.kinds import KINDS

    world = push_world()
    spec = ParameterSet(tuple(Parameter(KINDS[k], "small_box", value=v)
                              for k, v in (("frame_x", 0.005), ("frame_y", 0.0), ("frame_yaw", math.radians(3.0)))))
    trial = synthesize_trial("turn", world, push_telemetries()["turn"], odb, spec=spec, objects=("small_box",))
    nominal = ParameterSet(tuple(Parameter(KINDS[k], "small_box", value=0.0) for k in ("frame_x", "frame_y", "frame_yaw")))
    with make_executor("serial", odb) as executor:
        framed, = evaluate(executor, [trial], spec, [None])
        plain, = evaluate(executor, [trial], nominal, [None])
    assert framed.error.e_t < 1e-6 and framed.error.e_R < 1e-6
    assert 0.002 < plain.error.e_t < 0.02


@pytest.mark.slow
def test_a_frame_the_pushes_make_evident_is_held_there_and_only_the_friction_is_fitted_to_it(odb, tmp_path):
    """A mismatched world (its servo, contact, frictions and sensors differ from the model) recorded in a frame
    10 mm off the block's centre and turned 7 deg: the pushing samples read the frame before any simulation, the
    diagnosis holds `object_frame` there (`identify._held_frame`) and fits only the friction coefficients to it,
    so the replays' leftovers cannot pull the frame elsewhere (a mismatched rect1 world: a free fit went to a frame
    the samples refuse, and a rod offset was the verdict)."""
    from bridge.diagnosis.identify import _from_fit, _held_frame, _space
    from bridge.diagnosis.outline import frame_evidence

    case = Case("mit_steel_block", "object_frame", "large", 2, "mismatched")
    paths, truth = generate_case(case, odb, tmp_path / "case", 4)
    trials = load_trials(paths, odb)
    world, obj = trials[0].world, "steel_block"
    effect = get_effect("object_frame")
    with make_executor("serial", odb) as executor:
        runner = Runner([prepare(t, odb, 25.0) for t in trials], odb, executor)
        frame = frame_evidence(runner.prepared, odb, obj)
        held = _held_frame(frame)
        assert frame.evident and set(held) == set(truth.params), frame
        friction_params = _friction_parameters(world, odb, obj)
        space = _space(friction_params, effect, obj, world, odb, held)
        assert [p.name for p in space.free] == [p.name for p in friction_params]  # the frame is not fitted
        ev = Evaluator(runner, [0, 1, 2, 3])
        friction = ParameterSet(tuple(friction_params))
        ordinary = fit(ev, friction, np.zeros(friction.dim), max_iterations=3)
        framed = fit(ev, space, space.to_normal(ordinary.values()), max_iterations=3)
    scored = _from_fit("object_frame", obj, framed, world, odb)  # as the diagnosis reports it
    found = scored.params
    assert found == pytest.approx({k: v[0] for k, v in held.items()}) and not scored.measured
    recovery = effect.recovered(truth, found, (), world, odb)
    assert recovery.ok, recovery.text
    assert framed.chi2 < 0.5 * ordinary.chi2, (framed.chi2, ordinary.chi2)
