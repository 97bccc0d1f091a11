"""`bridge diagnose` end to end on generated clean recordings; `bridge prove` is exercised by test_prove."""
import json

import pytest

from bridge.cli import main
from bridge.diagnosis.report import validate
from bridge.diagnosis.scenarios import Case, generate_case


@pytest.mark.slow
def test_diagnose_writes_a_valid_report(odb, tmp_path, capsys):
    paths, _ = generate_case(Case("planar", "none", "medium", 2), odb, tmp_path / "clean", 3)
    out = tmp_path / "diag"
    assert main(["diagnose", *map(str, paths), "--out", str(out), "--workers", "1", "--hold-out", "1"]) == 0
    printed = capsys.readouterr().out
    assert "verdict: none" in printed
    data = json.loads((out / "diagnosis.json").read_text())
    validate(data)
    assert data["verdict"] == "none" and data["recordings"]["held_out"] and "held_out_before" in data["error"]
    assert (out / "report.md").read_text().startswith("# Diagnosis")
    assert (out / "paths.png").is_file() and (out / "effects.png").is_file()


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
    scene.write_text(yaml.safe_dump({"format": 1, "effects": [
        {"effect": "hidden_obstacle", "target": "surface", "params": {"x": ahead[0] + 0.06, "y": ahead[1]}}]}))
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
    assert main(["infer", str(rec), "--scene", str(scene), "--params", str(scene)]) == 1
    assert "either --params or --scene" in capsys.readouterr().err
