"""Shared fixtures: the object database and small generated proof cases (real Drake)."""

import pytest

pytest.importorskip("pydrake")


@pytest.fixture(scope="session")
def planar_world(odb):
    from bridge.prove.scenes import nominal_world, scene_spec

    return nominal_world(scene_spec("planar", odb), odb, (0.0, 0.0, 0.1))


@pytest.fixture
def evidence_report():
    """A `none` identification over `prepared` carrying one piece of evidence (`work=`, `rod=`, ...) and its
    sentence as a note: its diagnosis.json (schema-validated) and report, to check what the evidence writes."""
    from bridge.diagnosis.identify import Identification, Scored
    from bridge.diagnosis.loader import read_adjustments
    from bridge.diagnosis.locate import Localisation
    from bridge.diagnosis.report import diagnosis_json, report_markdown, validate
    from bridge.rollout.compare import PoseError

    def build(prepared, sentence: str, **evidence):
        error = PoseError(0.001, 0.01, 0.002, 100)
        none = Scored("none", "world", {}, {}, (), 0, 100.0, 100, error=error, held_out_chi2=100.0, held_out_n=100,
                      held_out_error=error)
        ident = Identification("none", (none,), Localisation(()), tuple(p.name for p in prepared), (), 1.0, (),
                               (sentence,), 0, 0.0, loader=read_adjustments(prepared, held_out=[]), **evidence)
        data = diagnosis_json(ident)
        validate(data)
        return data, report_markdown(ident, data, [])

    return build
