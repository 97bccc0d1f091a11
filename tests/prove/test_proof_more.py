"""The proof, small (second half, `proof_support`): the other effects, clean data in the diagnosis' own worlds and in
a mismatched one, and the proof's bookkeeping around its cases."""
import json

import pytest
from proof_support import case_named, check_diagnosed, check_scene_file_replays, diagnosed, params


@pytest.mark.slow
@pytest.mark.parametrize("case", params(first_half=False))
def test_concealed_effect_is_diagnosed(case, odb, proof_root, executor):
    check_diagnosed(case, odb, proof_root, executor)


@pytest.mark.slow
def test_scene_file_replays_the_diagnosed_model(odb, proof_root, executor):
    check_scene_file_replays("planar-hidden_obstacle-large-1", odb, proof_root, executor)


@pytest.mark.slow
def test_the_proof_starts_no_case_after_its_time_limit(odb, tmp_path, proof_root, executor, monkeypatch):
    """The proof's bookkeeping around its cases (the cases themselves are diagnosed above: the clean one's real
    result stands in for each, so this costs no diagnosis of its own)."""
    import time

    import bridge.prove.proof as proof_module
    from bridge.prove.proof import run_proof
    from bridge.prove.scenes import Case

    clean = diagnosed(case_named("planar-none-medium-1"), odb, proof_root, executor)

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
