"""The held-out rule of the verdict, on chi^2 figures (the fits themselves are proven in test_prove)."""
import math

from bridge.diagnosis.identify import Scored, _acceptable, _held_out_ok


def _scored(effect: str, each: list[tuple[float, int]]) -> Scored:
    return Scored(effect, "box", {}, {}, (), 0, math.nan, 0, held_out_chi2=sum(c for c, _ in each),
                  held_out_n=sum(n for _, n in each), held_out_each=tuple(each))


def test_a_quiet_held_out_recording_does_not_veto_one_the_effect_explains():
    # One held-out push hits the hidden obstacle (14 noise floors -> 2), the other stays at the floor (0.5 -> 0.95).
    # Unfloored, the ratios 0.14 (clipped to 0.25) and 1.9 average above 1: the quiet push would veto alone.
    # Floored at the noise level, the quiet push is a tie.
    n = 1000
    simpler = _scored("friction", [(14.0 * n, n), (0.5 * n, n)])
    model = _scored("hidden_obstacle", [(2.0 * n, n), (0.95 * n, n)])
    assert _held_out_ok(model, [simpler])


def test_a_model_that_makes_a_held_out_recording_worse_is_refused():
    n = 1000
    simpler = _scored("friction", [(3.0 * n, n), (3.0 * n, n)])
    model = _scored("surface_tilt", [(2.5 * n, n), (9.0 * n, n)])
    assert not _held_out_ok(model, [simpler])


def test_ties_at_the_noise_floor_accept_only_a_model_that_stays_there():
    n = 1000
    simpler = _scored("friction", [(0.9 * n, n), (0.8 * n, n)])
    assert _held_out_ok(_scored("mass", [(0.95 * n, n), (0.97 * n, n)]), [simpler])
    assert not _held_out_ok(_scored("mass", [(4.0 * n, n), (0.97 * n, n)]), [simpler])


def test_a_model_that_explains_most_of_the_held_out_excess_passes_though_one_quiet_push_rises():
    # The tabletop hidden obstacle: the push that hits it falls from 524 to 56 noise floors, the quiet one rises
    # from 0.7 to 10 (the fitted friction is still biased). Typical ratio: (4 + 0.25) / 2 > 1; excess: -87 %.
    simpler = _scored("none", [(162.0, 240), (124725.0, 238)])
    assert _held_out_ok(_scored("hidden_obstacle", [(2503.0, 240), (13418.0, 238)]), [simpler])
    assert not _held_out_ok(_scored("hidden_obstacle", [(2503.0, 240), (90000.0, 238)]), [simpler])


def test_a_model_stopped_by_a_bound_is_never_the_finding():
    """However much it explains: the recordings asked for a value outside the physical range."""
    n = 1000
    none = Scored("none", "", {}, {}, (), 0, 40.0 * n, n)
    friction = Scored("friction", "surface", {"friction[surface]": 1.5}, {}, (), 1, 2.0 * n, n,
                      at_bound={"friction[surface]": 1.5})
    why = _acceptable(friction, none, None, False, None, None)
    assert why is not None and "bound of friction[surface] = 1.5" in why
    assert _acceptable(Scored("friction", "surface", {"friction[surface]": 0.9}, {}, (), 1, 2.0 * n, n),
                       none, None, False, None, None) is None
