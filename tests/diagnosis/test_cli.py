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
