"""The diagnosis names a support pressure it was not given (real Drake): recordings of the proof's steel block
resting on a small disc (a mechanism other than the model's scaled footprint) turn more than simulated in every
push; an off-centre mass, which the same search also tries, turns some pushes more and some less."""
import pytest

from bridge.diagnosis.identify import Options
from bridge.diagnosis.pipeline import run_diagnosis
from bridge.prove.generate import generate_case
from bridge.prove.scenes import Case
from bridge.rollout import load_trials, make_executor


@pytest.mark.slow
def test_a_block_resting_on_a_small_disc_is_named_pressure_distribution(odb, tmp_path):
    paths, truth = generate_case(Case("planar", "pressure_distribution", "large", 1), odb, tmp_path / "case", 3)
    assert truth.params["support_scale[block]"] == 0.5
    options = Options(effects=("com_offset", "pressure_distribution"), max_full_fits=2, max_iterations=4)
    with make_executor("serial", odb) as executor:
        run = run_diagnosis(load_trials(paths, odb), odb, tmp_path / "diag", held_out=1, executor=executor,
                            options=options, plots=False)
    ident = run.identification
    assert ident.verdict == "pressure_distribution", [(s.effect, s.rms) for s in ident.scored]
    scale = ident.winner.params["support_scale[block]"]
    assert 0.35 <= scale <= 0.75  # concentrated towards the centre, as concealed
    e = run.data["error"]
    assert e["held_out_after"]["e"] < 0.5 * e["held_out_before"]["e"]  # and it predicts the push it did not see
