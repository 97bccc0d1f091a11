"""The small proof's cases and checks, shared by its two test files (test_proof.py, test_proof_more.py): the
cases are split so that the two halves run on two cores side by side (`--dist loadfile` keeps a file on one)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from bridge.diagnosis.report import validate
from bridge.prove.proof import SETTINGS, proof_cases, run_case

# CI runs six of the small proof's cases (its time limit: every case costs ~5 core-minutes): the effects whose
# search is hardest (non-smooth: a patch, a post; a tilt near the friction cone; a rod offset read from the
# contact gaps) and clean data in both worlds. friction, mass, com_offset and latency are proven by
# `bridge prove` and benchmarks/prove_benchmark.py (docs/diagnosis.md, section 6, gives each case's outcome).
CI_EFFECTS = ("surface_tilt", "friction_patch", "hidden_obstacle", "pusher_offset", "none")
CASES = [c for c in proof_cases("small", world="both") if c.effect in CI_EFFECTS]
FIRST_HALF = ("surface_tilt", "friction_patch")  # and the mismatched world: the two halves cost about the same
_RESULTS: dict = {}


def params(first_half: bool) -> list:
    """The cases of one half."""
    return [pytest.param(c, id=c.name) for c in CASES
            if (c.world == "mismatched" or c.effect in FIRST_HALF) == first_half]


def case_named(name: str):
    return next(c for c in CASES if c.name == name)


def diagnosed(case, odb, root: Path, executor):
    """The case's result, diagnosed once per test file (its folder under `root`)."""
    key = (str(root), case.name)
    if key not in _RESULTS:
        _RESULTS[key] = run_case(case, odb, root / case.name, SETTINGS["small"], executor=executor)
    return _RESULTS[key]


def check_diagnosed(case, odb, root: Path, executor) -> None:
    """The verdict is right (on a clean mismatched world whose frictions moved, `friction` is right too), the
    report validates, and for an effect: target, parameters, a lower held-out residual and a scene file."""
    result = diagnosed(case, odb, root, executor)
    assert result.right, result.to_json()
    data = json.loads((root / case.name / "diagnosis" / "diagnosis.json").read_text())
    validate(data)
    assert data["verdict"] == result.verdict
    if case.effect == "none":
        return
    assert result.target_ok, result.to_json()
    assert result.recovery.ok, result.recovery.text
    assert result.held_out_excess_reduction > 0, result.to_json()  # the held-out residual above the noise falls
    assert (root / case.name / "diagnosis" / "scene.yaml").is_file()


def check_scene_file_replays(name: str, odb, root: Path, executor) -> None:
    """The written scene.yaml, read as the parameter file it is and applied to a held-out recording, lowers that
    recording's error when replayed outside the diagnosis (the model is usable by infer, view, fit)."""
    import numpy as np

    from bridge.diagnosis.residuals import observed_series
    from bridge.params import apply_model, load_param_file, replay_model
    from bridge.rollout import Rollout, load_trials, pose_residual, run_rollout, sample_track
    from bridge.sim.simulate import SimOptions

    case = case_named(name)
    result = diagnosed(case, odb, root, executor)
    assert result.verdict == case.effect
    folder = root / name
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
