"""`bridge diagnose` end to end on generated clean recordings; `bridge prove` is exercised by test_prove."""
import json

import pytest

from bridge.cli import main
from bridge.diagnosis.report import validate
from bridge.prove.generate import generate_case
from bridge.prove.scenes import Case


@pytest.mark.slow
def test_diagnose_writes_a_valid_report(odb, tmp_path, capsys):
    paths, _ = generate_case(Case("planar", "none", "medium", 2), odb, tmp_path / "clean", 3)
    out = tmp_path / "diag"
    out.mkdir()
    (out / "scene.yaml").write_text("# an earlier diagnosis' scene file\n")  # stale beside a verdict of none
    (out / "residual_old_run_box.png").write_bytes(b"")
    assert main(["diagnose", *map(str, paths), "--out", str(out), "--workers", "1", "--hold-out", "1",
                 "--own-speed"]) == 0
    printed = capsys.readouterr().out
    assert "verdict: none" in printed
    data = json.loads((out / "diagnosis.json").read_text())
    validate(data)
    assert data["verdict"] == "none" and data["recordings"]["held_out"] and "held_out_before" in data["error"]
    assert data["rollouts"]["simulated"] + data["rollouts"]["cached"] == data["simulations"]
    report = (out / "report.md").read_text()
    assert report.startswith("# Diagnosis")
    # a clean world sits at the noise floor: the coarse step would be read as physics, the recordings' 2 ms stays
    assert data["time_step"]["time_step_s"] == 0.002 and data["time_step"]["note"] in report
    assert data["time_scales"]["taken"] == {} and "own speed, as asked" in data["time_scales"]["note"]
    assert data["time_scales"]["note"] in report
    assert (out / "paths.png").is_file() and (out / "effects.png").is_file()
    assert not (out / "scene.yaml").exists() and not (out / "residual_old_run_box.png").exists()  # one report
    assert not list(out.glob(".*"))  # no lock file, no temporary file


def test_diagnose_reports_bad_input_in_one_line(tmp_path, capsys):
    assert main(["diagnose", str(tmp_path / "missing"), "--out", str(tmp_path / "o")]) == 1
    assert "bridge diagnose: error:" in capsys.readouterr().err


@pytest.mark.slow
def test_infer_replays_with_a_diagnosed_scene_file(odb, tmp_path, capsys):
    """`bridge infer --scene` uses the diagnosed model: a post where the block is pushed stops it short."""
    import yaml

    from bridge.world import load_world_state

    paths, _ = generate_case(Case("planar", "none", "medium", 2), odb, tmp_path / "clean", 1)
    rec = paths[0]
    observed = [line.split(",") for line in (rec / "observed.csv").read_text().splitlines()[1:]]
    start, end = [float(v) for v in observed[0][2:4]], [float(v) for v in observed[-1][2:4]]
    ahead = [start[k] + 0.6 * (end[k] - start[k]) for k in (0, 1)]  # a post on the block's way
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump({"params": [
        {"kind": "obstacle_x", "target": "surface", "value": ahead[0] + 0.06, "effect": "hidden_obstacle"},
        {"kind": "obstacle_y", "target": "surface", "value": ahead[1], "effect": "hidden_obstacle"}]}))
    plain, blocked = tmp_path / "plain.yaml", tmp_path / "blocked.yaml"
    assert main(["infer", str(rec), "--world-out", str(plain)]) == 0
    assert main(["infer", str(rec), "--scene", str(scene), "--world-out", str(blocked)]) == 0
    x_plain = load_world_state(plain, odb).objects["block"].pose.xyz
    x_blocked = load_world_state(blocked, odb).objects["block"].pose.xyz
    travel = ((x_plain[0] - start[0]) ** 2 + (x_plain[1] - start[1]) ** 2) ** 0.5
    stopped = ((x_blocked[0] - start[0]) ** 2 + (x_blocked[1] - start[1]) ** 2) ** 0.5
    assert stopped < travel - 0.005
    assert main(["infer", str(rec), "--scene", str(tmp_path / "missing.yaml")]) == 1
    assert "missing.yaml" in capsys.readouterr().err
    # a fitted parameter file goes on top of the scene file: a sideways force drifts the stopped block
    params = tmp_path / "params.yaml"
    params.write_text("params:\n  - {kind: force_y, target: block, value: 5.0}\n")
    pushed = tmp_path / "pushed.yaml"
    assert main(["infer", str(rec), "--scene", str(scene), "--params", str(params), "--world-out", str(pushed)]) == 0
    assert load_world_state(pushed, odb).objects["block"].pose.xyz[1] > x_blocked[1] + 0.005


@pytest.mark.slow
def test_fit_runs_on_top_of_a_diagnosed_scene_file(odb, tmp_path, capsys):
    """`bridge fit --scene`: the scene file's model (here the recorder's clock shift) stays in every replay of the
    fit, so recordings made with that shift start (and end) far closer to the observations than without it."""
    import yaml

    paths, truth = generate_case(Case("planar", "latency", "large", 1), odb, tmp_path / "rec", 2)
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump({"params": [{"kind": "latency", "target": truth.target,
                                                 "value": float(truth.params["latency[pusher]"])}]}))
    errors = {}
    for name, extra in (("plain", []), ("scene", ["--scene", str(scene)])):
        out = tmp_path / name
        argv = ["fit", *map(str, paths), *extra, "--executor", "serial", "--generations", "1", "--popsize", "2",
                "--hold-out", "0", "--out", str(out)]
        assert main(argv) == 0, capsys.readouterr().err
        data = json.loads((out / "fit.json").read_text())
        errors[name] = (data["before"]["e"], data["after"]["e"])
    assert errors["scene"][0] < 0.5 * errors["plain"][0]
    assert errors["scene"][1] < 0.5 * errors["plain"][1]
    capsys.readouterr()
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"params": [{"kind": "com_x", "target": "tabel", "value": 0.01}]}))
    assert main(["fit", *map(str, paths), "--scene", str(bad), "--out", str(tmp_path / "bad")]) == 1
    err = capsys.readouterr().err.strip()
    assert "tabel" in err and "bad.yaml" in err and err.count("\n") == 0


@pytest.mark.slow
def test_diagnose_stops_at_its_time_limit_with_a_partial_verdict(odb, tmp_path, capsys):
    paths, _ = generate_case(Case("planar", "com_offset", "large", 1), odb, tmp_path / "case", 3)
    out = tmp_path / "diag"
    argv = ["diagnose", *map(str, paths), "--out", str(out), "--workers", "1", "--hold-out", "1", "--time-limit", "1"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    data = json.loads((out / "diagnosis.json").read_text())
    validate(data)
    assert data["stopped"] == "time limit" and data["time_limit_s"] == 1.0 and data["stopped_after_s"] >= 1.0
    untried = [c for c in data["candidates"] if c.get("note") == "not screened: time limit"]
    assert untried and any(n.startswith("partial: the time limit of 1 s stopped the search") for n in data["notes"])
    assert "Partial result" in (out / "report.md").read_text()
    assert "(partial: stopped at the time limit)" in captured.out
    assert "\r" not in captured.err and "diagnosis step 1/" in captured.err and "elapsed" in captured.err
