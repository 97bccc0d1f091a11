"""The proof, small (first half): every effect concealed by a physical mechanism in generated recordings (real
Drake) and diagnosed blind: the verdict names it, with the right target and parameters within the stated
tolerances (`bridge.diagnosis.prove.recovery`), the held-out error falls once it is modelled, clean recordings give
`none`, and every diagnosis.json validates against the schema (`proof_support`)."""
import pytest
from proof_support import check_diagnosed, params


@pytest.mark.slow
@pytest.mark.parametrize("case", params(first_half=True))
def test_concealed_effect_is_diagnosed(case, odb, proof_root, executor):
    check_diagnosed(case, odb, proof_root, executor)

