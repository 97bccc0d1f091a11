"""Make the paper's four trials (Section VI-B) as recordings under demo/recordings/, from the action templates'
bodies, simulated in Drake. Deterministic: running it again writes the same files.

    python demo/make_demo.py [--out demo/recordings] [--only 4_pick_place]

Each recording folder holds world.yaml (demo/worlds/tabletop.yaml), telemetry.csv (50 Hz), observed.csv (the
simulated poses before and after) and recording.yaml (the actions in the notes). `bridge demo` replays them.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bridge.enactment import make_plan_recording  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.planning import load_action_templates  # noqa: E402

WORLD = REPO / "demo" / "worlds" / "tabletop.yaml"

# (i) push one box over, (ii) push one box sliding over the table, (iii) push one box against the other,
# (iv) grasp a box and place it again (here: on the tray) -- the trial the paper had to drop.
TRIALS: dict[str, tuple[tuple[str, tuple[str, ...]], ...]] = {
    "1_push_over": (("push_over", ("arm", "big_box", "table")),),
    "2_slide": (("push", ("arm", "big_box", "table")),),
    "3_push_against": (("push_against", ("arm", "small_box", "big_box", "table")),),
    "4_pick_place": (("pick", ("arm", "small_box", "table")), ("place", ("arm", "small_box", "tray"))),
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "demo" / "recordings"), help="folder of the recordings")
    parser.add_argument("--only", action="append", choices=sorted(TRIALS), help="make only this trial (repeatable)")
    args = parser.parse_args(argv)
    odb = load_object_database()
    templates = load_action_templates(REPO / "pddl" / "templates", odb)
    status = 0
    for name, steps in TRIALS.items():
        if args.only and name not in args.only:
            continue
        started = time.perf_counter()
        recording = make_plan_recording(WORLD, steps, Path(args.out) / name, odb, templates, name=name, overwrite=True)
        ok = "WARNING" not in recording.notes
        status = status or (0 if ok else 1)
        print(f"{name}: {recording.telemetry.duration:.1f} s of telemetry, {len(recording.telemetry)} samples, "
              f"{'facts as the templates say' if ok else 'FACTS DIFFER (see recording.yaml)'} "
              f"({time.perf_counter() - started:.0f} s)")
    return status


if __name__ == "__main__":
    sys.exit(main())
