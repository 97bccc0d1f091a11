"""The effect-size benchmark's measure, through the real generator and Drake: a case and its twin without the
effect's mechanism differ by the effect alone."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from bridge.prove.scenes import Case

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from effect_size_benchmark import fitted_showing, push_difference, shows, summarise  # noqa: E402

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


def test_an_effect_only_the_held_out_pushes_show_is_counted_apart():
    """The mismatched proof's hex post (small, seed 2) moved the object in 2 of its 8 pushes, both of them the
    ones `bridge diagnose` holds out (rec_05 and rec_07): nothing the diagnosis fits shows the post, so the miss
    is counted among the cases no search could find, not among those whose fitted pushes show the effect."""
    quiet = {"object_mm": 0.2, "object_deg": 0.1, "rod_mm": 0.0, "log_force": 0.0}
    moved = {**quiet, "object_mm": 22.0}
    held_only = [quiet] * 5 + [moved, quiet, moved]
    assert fitted_showing(held_only) == 0 and sum(shows(p) for p in held_only) == 2
    seen = [moved, moved, moved, quiet, quiet, quiet, quiet, quiet]  # 3 of the 6 fitted pushes
    rows = [{"case": "a", "right": False, "pushes_showing": 2, "fitted_showing": 0, "pushes": held_only},
            {"case": "b", "right": True, "pushes_showing": 3, "fitted_showing": fitted_showing(seen), "pushes": seen},
            {"case": "c", "right": None, "pushes_showing": 3, "fitted_showing": 3, "pushes": seen}]
    summary = summarise(rows)
    assert summary["judged"] == 2 and summary["wrong"] == 1
    assert (summary["fitted_showing_in_half_or_more"], summary["right_of_those"]) == (1, 1)
