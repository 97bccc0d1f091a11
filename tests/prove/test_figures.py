"""The proof's figures from its case rows: what the benchmark prints against the issue's targets."""
from bridge.prove.proof import proof_text, summarise


def _row(case: str, effect: str, verdict: str, alike=(), moved: bool = False) -> dict:
    truth = {"effect": effect, "extra": {"mismatch": {"surface_friction": 0.3}} if moved else {}}
    return {"case": case, "effect": effect, "verdict": verdict, "alike": list(alike), "truth": truth,
            "target_ok": verdict == effect, "recovered": verdict == effect, "recovery": "", "seconds": 1.0,
            "held_out_excess_reduction": 0.8 if verdict == effect else None}


def test_rivals_the_recordings_do_not_tell_apart_are_counted_beside_the_right_verdicts():
    """A right verdict with an effect alike beside it is still right, but the proof says how often the recordings
    left a rival standing, and how often the concealed effect was at least among the effects they support (a
    wrong leader with the truth alike behind it is a miss that a user reading the rivals would not make)."""
    rows = [_row("a", "surface_tilt", "surface_tilt"),
            _row("b", "friction_patch", "friction_patch", alike=("friction_field",)),
            _row("c", "mass", "com_offset", alike=("mass",)),
            _row("d", "latency", "friction"),
            _row("e", "none", "friction", moved=True)]
    figures = summarise(rows)
    assert figures["verdict_right"] == 0.5 and figures["none_on_clean"] == 1.0
    assert figures["right_with_rivals"] == 0.5  # b of a, b
    assert figures["truth_supported"] == 0.75  # a, b, c of the four concealed
    assert "(alike: friction_field)" in proof_text(rows)
