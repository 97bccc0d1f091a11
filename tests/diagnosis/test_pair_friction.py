"""The diagnosis' ordinary parameters are an object's pair coefficients (with its support, with the robot), which
real materials have independent: a slippery rod on a block that grips its surface is fitted, through the real
Drake simulation, where per-body coefficients cannot reach it."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bridge.diagnosis.identify import _friction_parameters
from bridge.diagnosis.runs import Runner, prepare
from bridge.diagnosis.search import Evaluator, fit
from bridge.errors import ParameterError
from bridge.params import KINDS, ParameterSet, Setting, apply_model, check_values, parse_params, trial_rollout
from bridge.params.kinds import current_friction
from bridge.prove.generate import generate_case, noisy_track
from bridge.prove.scenes import NOISE_POSITION, NOISE_ROTATION
from bridge.prove.scenes import Case
from bridge.recording.observations import ObservedPoses
from bridge.rollout import load_trials, make_executor, run_rollout
from bridge.rollout.rollout import Rollout
from bridge.sim.friction import combined_friction
from bridge.sim.simulate import SimOptions
from bridge.values import Pose

ROD = "pusher/pusher_rod"


def _recorded(trials, truth, odb) -> list:
    """`trials` as recorded in a world with `truth`: the block's replayed track, with the proof's pose noise."""
    rng = np.random.default_rng(0)
    observed = []
    for trial in trials:
        end = float(trial.observations.tracks[0].times[-1])
        result = run_rollout(trial_rollout(trial, truth, odb), odb, SimOptions(sample_rate=100.0, end=end))
        track = noisy_track("block", result.times, result.tracks["block"], rng, (NOISE_POSITION, NOISE_ROTATION))
        observed.append(type(trial)(**{**vars(trial), "observations": ObservedPoses((track,))}))
    return observed


def test_pair_coefficients_are_realised_exactly_and_independently(planar_world, odb):
    """Each pair gets the value asked, the other stays; a sliding pair above twice the block's own coefficient
    (out of reach of the surface's coefficient alone) raises the block's and keeps the rod's pair."""
    block_mu = odb.get(planar_world.objects["block"].type).physics.mu_dynamic
    # the rod's coefficient, as models/pusher2d/pusher2d.sdf gives it (drake:mu_dynamic), is the link's null
    assert odb.get("planar_pusher").robot.link_friction == (("pusher_rod", 0.25),)
    assert KINDS["friction"].null(planar_world, odb, ROD) == 0.25

    def pairs(*settings):
        r = apply_model(list(settings), Rollout(planar_world, None), odb)
        b = current_friction(r, odb, "block")
        return combined_friction(b, current_friction(r, odb, "surface")), combined_friction(b, current_friction(r, odb, ROD))

    sliding0, rod0 = pairs()
    assert pairs(Setting("sliding_friction", "block", 0.1)) == pytest.approx((0.1, rod0))
    assert pairs(Setting("robot_friction", "block", 0.5)) == pytest.approx((sliding0, 0.5 * rod0))
    high = 2.5 * block_mu
    assert pairs(Setting("sliding_friction", "block", high), Setting("robot_friction", "block", 0.4)) == \
        pytest.approx((high, 0.4 * rod0))


def test_a_pair_the_world_does_not_have_is_refused_with_its_reason(planar_world, odb):
    """A parameter file's sliding pair for an object on no fixture, or robot pairs in a world without a robot,
    names the entry and why, before anything is simulated."""
    lifted = planar_world.with_poses({"block": Pose((0.0, 0.0, 0.3))})
    no_robot = dataclasses.replace(planar_world, robot=None)
    for world, kind, why in ((lifted, "sliding_friction", "'block' rests on no fixture"),
                             (no_robot, "robot_friction", "the world has no robot")):
        spec = parse_params({"params": [{"kind": kind, "target": "block", "value": 0.3}]}, "pairs.yaml")
        with pytest.raises(ParameterError) as err:
            check_values(spec, [Rollout(world, None)], odb)
        assert why in str(err.value) and "pairs.yaml" in str(err.value) and "params[0].value" in str(err.value)


@pytest.mark.slow
def test_a_slippery_rod_on_a_gripping_surface_is_fitted_as_its_two_pairs(odb, tmp_path):
    """Recordings of a world whose rod slips on the block (rod coefficient 0.05) while the block grips its surface
    (1.2): per-body coefficients of block and surface cannot give both pairs (the block's coefficient low enough
    for the rod's pair caps the sliding pair far below), the pair coefficients fit both."""
    paths, _ = generate_case(Case("planar", "none", "medium", 2), odb, tmp_path / "case", 2, force_noise=None)
    trials = load_trials(paths, odb)
    world = trials[0].world
    truth = (Setting("friction", ROD, 0.05), Setting("friction", "surface", 1.2))
    observed = _recorded(trials, truth, odb)
    r0 = odb.get("planar_pusher").robot.link_friction[0][1]
    b0 = odb.get(world.objects["block"].type).physics.mu_dynamic
    true_sliding, true_rod = combined_friction(b0, 1.2), combined_friction(b0, 0.05)
    # per body: the block's coefficient that gives the rod's pair leaves the surface's at most this sliding pair
    b_for_rod = true_rod * r0 / (2 * r0 - true_rod)
    assert combined_friction(b_for_rod, 1.5) < 0.6 * true_sliding

    with make_executor("serial", odb) as executor:
        runner = Runner([prepare(t, odb, 25.0) for t in observed], odb, executor)
        space = ParameterSet(tuple(_friction_parameters(world, odb, "block")))
        assert [p.kind.name for p in space.free] == ["sliding_friction", "robot_friction"]
        ev = Evaluator(runner, [0, 1])
        result = fit(ev, space, np.zeros(space.dim), max_iterations=10)
    found = result.values()
    assert found["sliding_friction[block]"] == pytest.approx(true_sliding, rel=0.2), found
    assert found["robot_friction[block]"] * combined_friction(b0, r0) == pytest.approx(true_rod, rel=0.3), found
    assert result.chi2 < 2.0 * result.n


@pytest.mark.slow
def test_a_stiffer_contact_is_taken_up_by_the_ordinary_model_with_its_contact_parameters(odb, tmp_path):
    """Recordings of a block whose contact is three times as stiff as the database's: the friction pairs alone leave
    a third more than the noise's chi^2 (what an effect fitted beside them would be credited with); with the
    contact's stiffness and damping among the ordinary parameters the fit reaches the noise and finds the
    stiffness."""
    paths, _ = generate_case(Case("planar", "none", "medium", 2), odb, tmp_path / "case", 2, force_noise=None)
    trials = load_trials(paths, odb)
    world = trials[0].world
    stiffness = odb.get(world.objects["block"].type).physics.hydroelastic_modulus
    truth = (Setting("hydroelastic_modulus", "block", 3.0 * stiffness), Setting("dissipation", "block", 0.3))
    observed = _recorded(trials, truth, odb)
    with make_executor("serial", odb) as executor:
        runner = Runner([prepare(t, odb, 25.0) for t in observed], odb, executor)
        ev = Evaluator(runner, [0, 1])
        fits = {}
        for contact in (False, True):
            space = ParameterSet(tuple(_friction_parameters(world, odb, "block", contact)))
            fits[contact] = fit(ev, space, np.zeros(space.dim), max_iterations=8)
    assert [p.kind.name for p in fits[True].space.free][2:] == ["hydroelastic_modulus", "dissipation"]
    assert fits[False].chi2 > 1.25 * fits[False].n
    assert fits[True].chi2 < 1.1 * fits[True].n
    assert fits[True].values()["hydroelastic_modulus[block]"] == pytest.approx(3.0 * stiffness, rel=0.3)
