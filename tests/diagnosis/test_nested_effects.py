"""An effect nested in another (`Effect.reduces_to`, `identify._nested`): a centre-of-mass fit that lands on the
centre with another mass is a fit of `mass`, and the search fits `mass` from it rather than refusing both."""
from types import SimpleNamespace

from bridge.diagnosis.identify import Candidate, Scored, _nested
from bridge.params import Setting


def odb_mass(odb, world) -> float:
    from bridge.sim.shapes import mass_properties

    return float(mass_properties(odb, world.objects["block"].type).mass)


def _com_fit(com_x: float, mass: float, chi2: float) -> Scored:
    params = {"com_x[block]": com_x, "com_y[block]": 0.0, "mass[block]": mass}
    model = (Setting("sliding_friction", "block", 0.31, "friction"), Setting("robot_friction", "block", 0.9, "friction"),
             *(Setting(k.split("[")[0], "block", v, "com_offset") for k, v in params.items()))
    return Scored("com_offset", "block", params, {}, model, 5, chi2, 100)


def test_a_centre_of_mass_on_the_centre_is_fitted_as_a_mass(odb, planar_world):
    screened = Candidate("mass", "block", 0.5, 900.0, {"mass[block]": 0.8, "mass_spread[block]": 0.0})
    order = [Candidate("com_offset", "block", 0.6, 800.0), screened]
    inner = _nested(order[0], _com_fit(1e-5, 1.6, 200.0), order, {}, planar_world, odb)
    assert inner is not None and (inner.effect, inner.target) == ("mass", "block")
    # the mass and the ordinary parameters where the centre-of-mass fit put them; the centre is not a mass kind
    assert inner.start["mass[block]"] == 1.6 and inner.start["sliding_friction[block]"] == 0.31
    assert inner.start["mass_spread[block]"] == 0.0 and "com_x[block]" not in inner.start


def test_no_mass_fit_from_a_centre_of_mass_that_matters_or_a_better_mass_fit(odb, planar_world):
    order = [Candidate("com_offset", "block", 0.6, 800.0), Candidate("mass", "block", 0.5, 900.0)]
    # a centre 5 mm off is a finding of its own
    assert _nested(order[0], _com_fit(0.005, 1.6, 200.0), order, {}, planar_world, odb) is None
    # nor from one whose mass is the database's too (within the mass's negligible 5 %)
    mass = odb_mass(odb, planar_world)
    assert _nested(order[0], _com_fit(1e-5, 1.02 * mass, 200.0), order, {}, planar_world, odb) is None
    assert _nested(order[0], _com_fit(1e-5, 1.2 * mass, 200.0), order, {}, planar_world, odb) is not None
    # `mass` already fitted as well or better
    done = {("mass", "block"): SimpleNamespace(chi2=150.0)}
    assert _nested(order[0], _com_fit(1e-5, 1.6, 200.0), order, done, planar_world, odb) is None
    # no nested effect screened (a catalog limited to com_offset), or an effect that nests none
    assert _nested(order[0], _com_fit(1e-5, 1.6, 200.0), order[:1], {}, planar_world, odb) is None
    patch = Candidate("friction_patch", "surface", 0.5, 900.0)
    assert _nested(patch, Scored("friction_patch", "surface", {}, {}, (), 6, 1.0, 10), [patch], {}, planar_world,
                   odb) is None
