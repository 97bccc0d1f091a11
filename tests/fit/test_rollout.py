"""Rollout through the real Drake simulation: the paper's error at observation times, failures, cached diagrams."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bridge.fit import rollout
from bridge.fit.error import PoseError
from bridge.fit.params import parse_params
from bridge.fit.rollout import FAILURE_ERROR, default_spec, evaluate, scene_for, simulate_trial
from bridge.fit.synthetic import TRUE_VALUES, recovery_spec
from bridge.recording.observations import ObservedPoses, ObservedTrack

FRICTIONS = ["friction[big_box]", "friction[table]"]


def test_truth_scores_zero_and_errors_grow_away_from_it(trials, odb):
    spec = recovery_spec(FRICTIONS)
    truth = [TRUE_VALUES[n] for n in FRICTIONS]
    total, per_trial = evaluate(trials, spec, truth, odb=odb)
    assert total.e < 1e-9 and [e.trial for e in per_trial] == ["slide", "turn"]
    near, _ = evaluate(trials, spec, [truth[0] + 0.05, truth[1]], odb=odb)
    far, per_far = evaluate(trials, spec, [truth[0] + 0.2, truth[1]], odb=odb)
    assert 0 < near.e < far.e
    assert far == PoseError.merge(e.error for e in per_far)  # eq. 4 over every sample of every trial
    assert far.e ** 2 == pytest.approx(far.e_t ** 2 + 0.01 * far.e_R ** 2)
    assert far.count == sum(2 * int(np.sum(t.observations.tracks[0].times > 0)) for t in trials)


def test_a_failed_simulation_scores_a_large_finite_error(slide, odb):
    spec = parse_params({"params": [{"kind": "force_z", "target": "small_box", "bounds": [-1e5, 0]}]})
    total, (err,) = evaluate(slide, spec, [-1e5], odb=odb)
    assert err.failed and "went through 'table'" in err.failure
    assert total.e == FAILURE_ERROR and np.isfinite(total.e)
    assert rollout.failures([err]) == {"slide": err.failure}


def test_one_diagram_per_structure_and_a_fresh_context_per_evaluation(trials, odb):
    slide_scene, turn_scene = scene_for(trials[0], odb), scene_for(trials[1], odb)
    assert slide_scene is turn_scene  # same objects, fixtures, robot: one diagram
    spec = recovery_spec(["mass[small_box]", "com_z[big_box]"])
    first = evaluate(trials, spec, [0.8, -0.05], odb=odb)[0]
    evaluate(trials, spec, [0.2, 0.05], odb=odb)
    again = evaluate(trials, spec, [0.8, -0.05], odb=odb)[0]
    assert again == first  # nothing of the second evaluation stayed behind in the reused diagram
    assert scene_for(trials[0], odb) is slide_scene


def test_sparse_observations_compare_with_the_objects_at_rest(slide, odb):
    trial = slide[0]
    final = simulate_trial(dataclasses.replace(trial, observations=ObservedPoses(())), recovery_spec(()), None,
                           odb=odb)
    at_rest = final.final_poses["small_box"]  # after the default 0.5 s of settling
    start = trial.world.objects["small_box"].pose
    sparse = ObservedPoses((ObservedTrack("small_box", np.array([0.0, trial.telemetry.end]), (start, at_rest)),))
    sparse_trial = dataclasses.replace(trial, observations=sparse)
    assert sparse_trial.settle == 0.5
    total, _ = evaluate([sparse_trial], recovery_spec(()), [], odb=odb)
    assert total.count == 1 and total.e < 1e-9


def test_default_parameters_are_the_friction_of_the_moved_objects_and_what_they_touch(trials, odb):
    spec = default_spec(trials, odb)
    assert set(spec.names) == {"friction[big_box]", "friction[small_box]", "friction[table]"}
    assert all(p.start == odb.get(p.target).physics.friction for p in spec.free)


def test_nominal_physics_on_a_real_mit_push(mit_push_root, odb):
    """Nominal values (odb/types/mit_push.yaml) replay a real push to within a few millimetres."""
    from bridge.fit.trials import load_trials

    name = "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.800_t=-0.349.h5"
    (trial,) = load_trials([mit_push_root / "train" / name], odb, max_duration=0.8)
    total, _ = evaluate([trial], default_spec([trial], odb), None, odb=odb)
    assert total.e < 0.005, total
