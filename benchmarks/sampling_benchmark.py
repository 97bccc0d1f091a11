"""Fact probabilities from parameter samples (`bridge infer --samples N`): what N costs and what it buys.

The scene is the near-tipping push of tests/test_uncertainty.py (a 25 cm box on the table, the planar rod pushing
at 10.2 cm, where about half of the database's friction range tips it), replayed with parameters drawn from the
object database's ranges. Reported:
1. wall time of `sample_session` for N = 1, 8, 32 on a process pool of 2 workers (the nominal replay included);
2. how many samples the probability of (upright big_box) needs to settle within 0.05 of a 128-sample reference,
   over 4 seeds, with the Latin hypercube bridge uses and with independent draws beside it.

    python benchmarks/sampling_benchmark.py [--quick]

Prints a table and writes benchmarks/results/sampling.json.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))

from bridge.odb import load_object_database  # noqa: E402
from bridge.rollout import Rollout, make_executor  # noqa: E402
from bridge.uncertainty import sample_session  # noqa: E402
from test_uncertainty import NEAR, UPRIGHT, push, tipping_world  # noqa: E402

SETTLE = 0.05


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="reference of 32 samples, N up to 16, 2 seeds")
    args = parser.parse_args()
    reference_n, sizes, seeds = (32, (4, 8, 16), (1, 2)) if args.quick else (128, (4, 8, 16, 32, 64), (1, 2, 3, 4))
    odb = load_object_database()
    rollout = Rollout(tipping_world(NEAR), push())
    started = time.perf_counter()
    with make_executor("process", odb, workers=2) as executor:
        sample_session(rollout, odb, 2, executor=executor)  # warm the workers up (Drake imported, scene built)
        timing = []
        for n in (1, 8, 32):
            t = time.perf_counter()
            sample_session(rollout, odb, n, executor=executor, seed=0)
            timing.append({"samples": n, "wall_s": round(time.perf_counter() - t, 2)})
            print(f"N = {n:3d}: {timing[-1]['wall_s']:6.1f} s on 2 workers", flush=True)
        reference = sample_session(rollout, odb, reference_n, executor=executor, seed=99).probabilities[UPRIGHT]
        print(f"reference: p(upright) = {reference:.3f} from {reference_n} samples", flush=True)
        rows = []
        for method in ("lhs", "mc"):
            for n in sizes:
                errors = [abs(sample_session(rollout, odb, n, executor=executor, seed=s, method=method)
                              .probabilities.get(UPRIGHT, 0.0) - reference) for s in seeds]
                rows.append({"method": method, "samples": n, "max_error": round(max(errors), 3),
                             "mean_error": round(sum(errors) / len(errors), 3)})
                print(f"{method:4s} N = {n:3d}: |p - reference| mean {rows[-1]['mean_error']:.3f}, "
                      f"max {rows[-1]['max_error']:.3f} over {len(seeds)} seeds", flush=True)
    settled = {m: next((r["samples"] for r in rows if r["method"] == m and r["max_error"] <= SETTLE), None)
               for m in ("lhs", "mc")}
    print(f"settled within {SETTLE} (every seed): latin hypercube at N = {settled['lhs']}, independent draws at "
          f"N = {settled['mc']} (None: not within the sizes tried)")
    out = REPO / "benchmarks" / "results" / ("sampling_quick.json" if args.quick else "sampling.json")
    out.write_text(json.dumps({"scene": "near-tipping push, database ranges", "reference_samples": reference_n,
                               "reference_p_upright": reference, "timing": timing, "convergence": rows,
                               "settled": settled, "cpus": os.cpu_count(),
                               "total_s": round(time.perf_counter() - started, 1)}, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
