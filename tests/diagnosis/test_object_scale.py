"""The object's size is part of its model too: recordings of an object 5 % larger (or smaller) than its model
are out of reach of the friction coefficients, and the size is fitted back through the real Drake simulation.
The scaled object rests where the world puts it, weighs what the database says and turns with the inertia of its
size."""
from __future__ import annotations

import numpy as np
import pytest

from bridge.diagnosis.effects import Evidence, get_effect
from bridge.diagnosis.effects.object_scale import outline_radius
from bridge.diagnosis.identify import _friction_parameters, _scale_check
from bridge.diagnosis.runs import Runner, chi2_of, prepare
from bridge.diagnosis.search import Evaluator, fit
from bridge.errors import SceneError
from bridge.params import ParameterSet, apply_model
from bridge.prove.generate import generate_case
from bridge.prove.scenes import Case
from bridge.rollout import load_trials, make_executor
from bridge.rollout.rollout import Rollout, scene_for


def test_a_scaled_object_rests_where_it_stood_with_its_mass_and_a_larger_inertia(planar_world, odb):
    from bridge.rollout.rollout import run_rollout
    from bridge.sim.simulate import SimOptions

    effect = get_effect("object_scale")
    rollout = apply_model(effect.model(planar_world, odb, "block", {"object_scale[block]": 1.1}),
                          Rollout(planar_world, None), odb)
    figures = []
    for r in (Rollout(planar_world, None), rollout):
        scene = scene_for(r, odb)
        inertia = scene.bodies["block"].CalcSpatialInertiaInBodyFrame(scene.plant.CreateDefaultContext())
        izz = inertia.Shift(inertia.get_com()).CalcRotationalInertia().CopyToFullMatrix3()[2, 2]  # about the com
        track = run_rollout(r, odb, SimOptions(end=0.3, sleep=False)).tracks["block"]
        figures.append((inertia.get_mass(), izz, float(np.ptp(track[:, 2]))))
    (m0, izz0, sink0), (m1, izz1, sink) = figures
    assert m1 == pytest.approx(m0)  # the object weighs what it weighs
    assert izz1 == pytest.approx(1.21 * izz0)  # its inertia goes with its size
    assert sink < sink0 + 2e-5, (sink0, sink)  # it settles into the table as the model does: no drop, no jump
    assert apply_model(effect.model(planar_world, odb, "block", {}), Rollout(planar_world, None), odb).extras == ()


def test_a_scale_on_a_fixture_is_refused(planar_world, odb):
    from bridge.sim.extras import ObjectScale

    with pytest.raises(SceneError) as err:
        scene_for(Rollout(planar_world, None).with_extras(ObjectScale("table", 1.05)), odb)
    assert "no free object 'table'" in str(err.value)


def test_a_rod_that_pushed_outside_the_outline_on_every_side_seeds_a_larger_object(planar_world, odb):
    """The contact gaps (read before any simulation) put the rod 2 mm outside the block's outline on every side:
    the size that puts it there is a seed, and the signature says the object model is the suspect."""
    effect = get_effect("object_scale")
    plain, seen = Evidence((), planar_world, odb), Evidence((), planar_world, odb, inflation=0.002)
    size = odb.get(planar_world.objects["block"].type).geometry.size
    # a box's outline lies, on average over its length, 2 area / perimeter from its centre (its faces' distance
    # on a square)
    radius = outline_radius(planar_world, odb, "block")
    assert radius == pytest.approx(size[0] * size[1] / (size[0] + size[1]))
    assert effect.seeds(seen, "block")[0]["object_scale[block]"] == pytest.approx(1.0 + 0.002 / radius)
    assert len(effect.seeds(plain, "block")) == 3
    assert effect.signature(seen, "block") > effect.signature(plain, "block")


@pytest.mark.slow
def test_recordings_of_an_object_of_another_size_are_fitted_back(odb, tmp_path):
    """Recordings of a block 5 % smaller than its model (the proof's medium size, the pushes placed clear of the
    real block): friction alone leaves three noise floors; the size fitted with it does as well as the truth and
    finds it (0.943 for 0.95)."""
    paths, truth = generate_case(Case("planar", "object_scale", "medium", 1), odb, tmp_path / "case", 3,
                                 force_noise=None)
    trials = load_trials(paths, odb)
    world = trials[0].world
    effect = get_effect("object_scale")
    with make_executor("serial", odb) as executor:
        runner = Runner([prepare(t, odb, 25.0) for t in trials], odb, executor)
        ev = Evaluator(runner, [0, 1, 2])
        friction = ParameterSet(tuple(_friction_parameters(world, odb, "block")))
        ordinary = fit(ev, friction, np.zeros(friction.dim), max_iterations=6)
        space = ParameterSet(tuple(_friction_parameters(world, odb, "block")) + effect.parameters(world, odb, "block"))
        starts = [space.to_normal({**ordinary.values(), **seed})
                  for seed in effect.seeds(Evidence((), world, odb), "block")]
        chis = [ev.chi2(space.model(space.from_normal(x))) for x in starts]
        sized = fit(ev, space, starts[int(np.argmin(chis))], max_iterations=8)
        exact, n = chi2_of(runner.run(effect.model(world, odb, "block", truth.params), [0, 1, 2]))
    assert exact < 2.5 * n
    assert ordinary.chi2 > 3 * exact, "friction alone explains another size: the test shows nothing"
    assert sized.chi2 < 1.2 * exact, (sized.values(), sized.chi2 / n, exact / n)
    recovery = effect.recovered(truth, sized.values(), (), world, odb)
    assert recovery.ok, recovery.text


def _sized(scale: float):
    from bridge.diagnosis.identify import Scored

    return Scored("object_scale", "block", {"object_scale[block]": scale}, {}, (), 3, 0.0, 1)


def test_a_fitted_size_the_contact_gaps_do_not_show_is_contradicted():
    """A stiff rod that does not sink into the object as Drake's compliant one does left gaps of -0.01 +- 0.03 mm
    (an independent MuJoCo world), and a fit through the simulation made the object 1.75 % larger (+0.9 mm on an
    ellip1) to push it earlier: the gaps measured no such size. A size the gaps show stands, within the spread of
    the outline's distances from its centre; without gaps (no planar pusher) nothing is contradicted."""
    from bridge.diagnosis.loader import ContactFit

    def gaps(inflation: float, sd: float) -> ContactFit:
        return ContactFit(("pusher_x", "pusher_y"), (0.0, 0.0), inflation, ((1e-8, 0.0), (0.0, 1e-8)), sd,
                          1e-4, 1e-4, 6)

    radius = 0.0524  # ellip1's
    why = _scale_check(_sized(1.0175), gaps(-1e-5, 2.6e-5), radius)
    assert why is not None and "+1.8 %" in why and "-0.01" in why
    assert _scale_check(_sized(1.0175), gaps(0.8e-3, 0.1e-3), radius) is None  # the gaps show the larger object
    assert _scale_check(_sized(0.92), gaps(-4.0e-3, 0.2e-3), radius) is None  # within the outline's spread
    assert _scale_check(_sized(1.008), gaps(0.0, 2.6e-5), radius) is None  # 0.4 mm: a size nobody acts on
    assert _scale_check(_sized(1.0175), None, radius) is None


def test_a_size_no_object_can_have_is_refused_naming_the_file_and_field(planar_world, odb):
    from bridge.errors import ParameterError
    from bridge.params import check_values, parse_params

    with pytest.raises(ParameterError) as err:
        spec = parse_params({"params": [{"kind": "object_scale", "target": "block", "value": 3.0}]}, "size.yaml")
        check_values(spec, [Rollout(planar_world, None)], odb)
    text = str(err.value)
    assert "size.yaml" in text and "params[0].value" in text and "object_scale" in text
