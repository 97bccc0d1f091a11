"""The fit driver through real Drake: recovery of known parameters with both optimisers, hold-out, checkpoints,
the report and the `bridge fit` command."""
from __future__ import annotations

import json

import pytest
import yaml

from bridge.cli import main
from bridge.errors import FitError
from bridge.fit.fit import CHECKPOINT_FILE, fit_parameters, split_hold_out
from bridge.fit.report import table1, write_report
from bridge.fit.synthetic import TRUE_VALUES, recovery, recovery_spec
from bridge.params import KINDS
from bridge.rollout import load_trials
from bridge.recording.recording import save_recording
from bridge.world import save_world_state

FRICTIONS = ("friction[big_box]", "friction[table]")
MASS_COM = ("mass[small_box]", "com_z[big_box]")
# Stated tolerances of the recovery (noise-free synthetic recordings, wrong start, <= 12 generations).
TOLERANCE = {"friction[big_box]": 0.04, "friction[table]": 0.04, "mass[small_box]": 0.05, "com_z[big_box]": 0.005}
POPSIZE = {"cmaes": 6, "es": 12, "lm": None}


@pytest.mark.slow
@pytest.mark.parametrize("optimizer", ["cmaes", "es", "lm"])
@pytest.mark.parametrize("names", [FRICTIONS, MASS_COM], ids=["frictions", "mass+com"])
def test_recovers_known_parameters_from_a_wrong_start(optimizer, names, trials, odb, pool):
    spec = recovery_spec(names)
    result = fit_parameters(trials, spec, odb=odb, executor=pool, optimizer=optimizer, seed=3, generations=12,
                            popsize=POPSIZE[optimizer], hold_out=0)
    start = recovery(dict(result.start))
    assert not start.within(TOLERANCE)  # the start really is wrong
    found = recovery(dict(result.values))
    assert found.within(TOLERANCE), (found, result.stop_reason)
    assert result.after.e < 0.1 * result.before.e and result.failures == 0
    assert sum(result.rollouts.values()) == result.simulations  # every replay asked for: run, or from the cache
    if optimizer == "lm":  # it evaluates the start again, which the fit scored first: not simulated twice
        assert result.rollouts["cached"] >= len(trials)


def test_hold_out_split_is_seeded_and_keeps_order():
    names = [f"t{i}" for i in range(8)]
    fit, held = split_hold_out(names, None, seed=1)
    assert len(held) == 2 and len(fit) == 6 and list(fit) == [n for n in names if n not in held]
    assert split_hold_out(names, None, seed=1) == (fit, held)
    assert split_hold_out(names[:3], None, seed=1) == (tuple(names[:3]), ())  # too few to hold any out
    assert len(split_hold_out(names[:4], None, seed=0)[1]) == 1
    assert len(split_hold_out(names, 3, seed=0)[1]) == 3
    with pytest.raises(FitError, match="cannot hold out 8 of 8"):
        split_hold_out(names, 8, seed=0)


def _small_fit(trials, odb, **kwargs):
    return fit_parameters(trials, recovery_spec(FRICTIONS), odb=odb, seed=5, generations=4, popsize=4, hold_out=0,
                          **kwargs)


class _Stop(Exception):
    pass


@pytest.mark.parametrize("optimizer", ["cmaes", "es"])
def test_resuming_a_checkpoint_gives_the_uninterrupted_result(optimizer, slide, odb, tmp_path):
    whole = _small_fit(slide, odb, optimizer=optimizer)

    def stop_after_two(progress):
        if progress.generation == 2:
            raise _Stop

    with pytest.raises(_Stop):
        _small_fit(slide, odb, optimizer=optimizer, checkpoint=tmp_path, progress=stop_after_two)
    assert json.loads((tmp_path / CHECKPOINT_FILE).read_text())["optimizer"]["progress"]["generation"] == 2
    resumed = _small_fit(slide, odb, optimizer=optimizer, checkpoint=tmp_path, resume=True)
    assert resumed.values == whole.values
    assert resumed.history == whole.history and resumed.generation_errors[-1].best == whole.generation_errors[-1].best
    assert (resumed.evaluations, resumed.simulations) == (whole.evaluations, whole.simulations)
    assert resumed.before == whole.before and resumed.after == whole.after


def test_resume_refuses_another_fit_or_a_missing_checkpoint(slide, odb, tmp_path):
    with pytest.raises(FitError, match="no checkpoint to resume from"):
        _small_fit(slide, odb, optimizer="es", checkpoint=tmp_path, resume=True)
    _small_fit(slide, odb, optimizer="es", checkpoint=tmp_path)
    with pytest.raises(FitError, match="different fit \\(optimizer, seed differ\\)"):
        fit_parameters(slide, recovery_spec(FRICTIONS), odb=odb, seed=6, generations=4, popsize=4, hold_out=0,
                       optimizer="cmaes", checkpoint=tmp_path, resume=True)


def test_report_files_and_table(trials, odb, tmp_path):
    result = _small_fit(trials, odb, optimizer="cmaes")
    files = write_report(result, tmp_path, trials=trials, odb=odb)
    assert set(files) == {"params.yaml", "fit.json", "table1.md", "fig4_params.png", "fig4_errors.png"}
    data = json.loads(files["fit.json"].read_text())
    for key in ("params", "before", "after", "optimizer", "seed", "generations", "evaluations", "failures", "history"):
        assert key in data, key
    assert set(data["params"]) == set(FRICTIONS) and data["before"]["e"] > data["after"]["e"]
    assert len(data["history"]) == result.generations == 4
    assert set(data["history"][0]["best"]) == set(FRICTIONS)
    fitted = yaml.safe_load(files["params.yaml"].read_text())["params"]
    assert {(p["kind"], p["target"]) for p in fitted if "value" in p} >= {("friction", "big_box"), ("friction", "table")}
    text = table1(result)
    assert "initial generation" in text and "generation 4" in text and "e_R" in text
    assert files["fig4_params.png"].stat().st_size > 10_000


def _as_recording(trial, folder):
    world_yaml = folder.parent / f"{trial.name}_world.yaml"
    save_world_state(trial.world, world_yaml)
    save_recording(folder, world_yaml, trial.telemetry, trial.observations)
    return folder


def test_bridge_fit_command_on_recording_folders(trials, odb, tmp_path, capsys):
    folders = [_as_recording(t, tmp_path / "recordings" / t.name) for t in trials]
    loaded = load_trials(folders, odb)
    assert [t.name for t in loaded] == ["slide", "turn"] and loaded[0].observations.is_dense
    params = tmp_path / "params.yaml"
    params.write_text(yaml.safe_dump(recovery_spec(FRICTIONS).to_dict()))
    out = tmp_path / "out"
    argv = ["fit", *map(str, folders), "--params", str(params), "--executor", "serial", "--generations", "2",
            "--popsize", "4", "--out", str(out)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "initial generation" in captured.out and "generation 2/2" in captured.err
    fitted = out / "params.yaml"
    data = json.loads((out / "fit.json").read_text())
    assert data["generations"] == 2 and data["held_out_trials"] == []
    # the fitted file drives bridge infer
    assert main(["infer", str(folders[0]), "--params", str(fitted), "--world-out", str(tmp_path / "w.yaml")]) == 0
    capsys.readouterr()
    bad = tmp_path / "bad.yaml"
    bad.write_text("params:\n  - {kind: friction, target: tabel, value: 0.3}\n")
    assert main(["infer", str(folders[0]), "--params", str(bad)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "'tabel' names nothing" in err and "bad.yaml" in err


@pytest.mark.slow
def test_bridge_fit_accepts_every_kind(slide, odb, tmp_path, capsys):
    """One parameter file naming every kind of the registry (the tilt, the post and the patch among them) fits
    end to end: each candidate rebuilds what it must and replays."""
    trial = slide[0]
    folder = _as_recording(trial, tmp_path / "recordings" / trial.name)
    entries = []
    for name, kind in KINDS.items():
        target = {"robot": "pusher", "joints": "pusher_x", "surfaces": "table"}.get(kind.targets, "big_box")
        null, step = kind.null(trial.world, odb, target), kind.step(trial.world, odb, target)
        lo, hi = kind.bounds(trial.world, odb, target)
        entries.append({"kind": name, "target": target, "bounds": [max(lo, null - step), min(hi, null + step)],
                        "start": null})
    params = tmp_path / "every.yaml"
    params.write_text(yaml.safe_dump({"params": entries}))
    out = tmp_path / "out"
    argv = ["fit", str(folder), "--params", str(params), "--executor", "serial", "--generations", "1", "--popsize",
            "2", "--hold-out", "0", "--out", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    data = json.loads((out / "fit.json").read_text())
    assert set(data["params"]) == {f"{e['kind']}[{e['target']}]" for e in entries}


def test_fit_needs_free_parameters_and_trials(slide, odb):
    with pytest.raises(FitError, match="no free parameter"):
        fit_parameters(slide, recovery_spec(()), odb=odb)
    with pytest.raises(FitError, match="no trials"):
        fit_parameters([], recovery_spec(FRICTIONS), odb=odb)
    assert TRUE_VALUES  # the truth the recovery test compares with


def test_optimizer_choices_are_checked(slide, odb, tmp_path):
    with pytest.raises(FitError, match="unknown optimizer 'ga'; valid: cmaes, es, lm"):
        fit_parameters(slide, recovery_spec(FRICTIONS), odb=odb, optimizer="ga")
    with pytest.raises(FitError, match="Levenberg-Marquardt fit keeps no checkpoint"):
        fit_parameters(slide, recovery_spec(FRICTIONS), odb=odb, optimizer="lm", checkpoint=tmp_path, resume=True)


# --- a time limit ------------------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_bridge_fit_stops_at_its_time_limit_and_still_writes_the_best_so_far(slide, odb, tmp_path, capsys):
    folder = _as_recording(slide[0], tmp_path / "recordings" / "slide")
    params = tmp_path / "params.yaml"
    params.write_text(yaml.safe_dump(recovery_spec(FRICTIONS).to_dict()))
    out = tmp_path / "out"
    argv = ["fit", str(folder), "--params", str(params), "--executor", "serial", "--generations", "30", "--popsize",
            "4", "--hold-out", "0", "--time-limit", "1", "--out", str(out)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    data = json.loads((out / "fit.json").read_text())
    assert data["stopped"] == "time limit" and data["time_limit_s"] == 1.0 and data["stopped_after_s"] >= 1.0
    assert 1 <= data["generations"] < 30 == data["max_generations"]
    assert "time limit" in data["stop_reason"] and data["after"]["e"] <= data["before"]["e"]
    assert (out / "params.yaml").is_file() and "partial" in (out / "params.yaml").read_text()
    assert "Partial result" in (out / "table1.md").read_text() and "partial result" in captured.out
    # progress off a terminal: plain lines with the time left, and the whole fit's estimate after generation 1
    assert "\r" not in captured.err
    assert "generation 1/30 (3%)" in captured.err and "elapsed" in captured.err
    assert "the first generation took" in captured.err and "the 29 left take about" in captured.err
    assert "the time limit stops it after 1.0 s" in captured.err


@pytest.mark.slow
def test_a_levenberg_marquardt_fit_stops_at_its_time_limit(slide, odb):
    result = fit_parameters(slide, recovery_spec(FRICTIONS), odb=odb, optimizer="lm", generations=20, hold_out=0,
                            time_limit=0.01)
    assert result.stopped == "time limit" and result.partial and result.generations == 1
    assert set(result.values) == set(FRICTIONS) and result.std == {}
