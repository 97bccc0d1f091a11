"""The effect-size benchmark's measure, through the real generator and Drake: a case and its twin without the
effect's mechanism differ by the effect alone."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from bridge.prove.scenes import Case

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from effect_size_benchmark import push_difference, shows  # noqa: E402

SHAPE = "mit_steel_block"  # a box in the MIT format: no dataset needed


@pytest.mark.slow
def test_a_case_and_its_twin_differ_by_the_effect_alone(odb, tmp_path):
    """`concealed=False` writes the same pushes, world and noise without the effect's mechanism: a slug twice the
    block's mass, welded at its centre, scales the force the rod feels by about the mass while the twin's rod starts
    and moves as the case's (what `benchmarks/effect_size_benchmark.py` measures every effect of the proof by)."""
    from bridge.prove.generate import generate_case
    from bridge.recording.mitpush import load_push

    case = Case(SHAPE, "mass", "large", 1, "mismatched")
    concealed, truth = generate_case(case, odb, tmp_path / "case", 2)
    twin, twin_truth = generate_case(case, odb, tmp_path / "twin", 2, concealed=False)
    assert twin_truth.params == truth.params and twin_truth.extra.get("concealed") is False
    for a, b in zip(concealed, twin):
        pa, pb = load_push(a), load_push(b)
        np.testing.assert_allclose(pa.tip_xy[0], pb.tip_xy[0], atol=1e-9)  # the same push, from the same place
        size = push_difference(a, b)
        assert shows(size)
        assert 0.6 * math.log(3.0) < size["log_force"] < 1.3 * math.log(3.0), size  # mass x 3
    same = push_difference(twin[0], twin[0])
    assert not shows(same) and same["object_mm"] == 0.0
