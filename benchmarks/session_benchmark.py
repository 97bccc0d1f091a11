"""A realistic teleoperation session replayed by bridge, beside a full 1 ms simulation and a naive MuJoCo replay.

The session (bridge/session.py, FULL_SESSION): the demo arm over a table with nine objects, eleven actions made
from the action templates' bodies (push over, slide, push against, pick and place, stand up) with the
operator's free motion between them, 5 minutes, about 80 % of it touching nothing. It is generated once,
deterministically, into benchmarks/results/session/ (regenerated when the plan or the code that makes it
changes, or with --regenerate) and replayed:

1. as the reference: every object simulated at a 1 ms step (`SimConfig(time_step=0.001)`,
   `SimOptions(sleep=False)`); bridge's facts are compared with its facts and its final poses (max mm / deg).
   Cached beside the session (keyed on the recording, bridge/sim's sources and Drake's version) unless
   --fresh-reference;
2. by bridge with its defaults (`bridge infer`: SimConfig(), SimOptions()): end-to-end real-time factor, the
   contact phases' real-time factor (the spans where the robot touches something in the reference's contact
   log; and `ReplayResult.awake`, the spans stepped with contact dynamics, when the replay reports them), and
   the time from the end of the telemetry to the PDDL problem written (after the fact, and on-line: a replay
   running alongside telemetry that arrives in real time, so a replay slower than real time carries a backlog);
3. when bridge's replay sleeps objects: the full simulation at bridge's own 2 ms step, for the gain alone;
4. in MuJoCo (`pip install -e .[bench]`), naively: the same robot and objects converted from the same models
   (benchmarks/mujoco_scene.py), the same telemetry through PD actuators with the same gains, every 2 ms step
   simulated; its facts (bridge's SIEs on MuJoCo's final state) and final poses against the reference, and the
   ratio of bridge's wall time to MuJoCo's.

Real-time factors are given on wall time and on CPU time (the machine is shared: CPU time is what one replay
costs). `--session short` runs the tests' short session instead (a minute, for trying the script out).

    python benchmarks/session_benchmark.py [--session full|short] [--regenerate] [--fresh-reference] [--no-mujoco]

Prints a table and writes benchmarks/results/session.json (session_short.json for the short session).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import platform
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from importlib import metadata
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from bridge.files import write_atomic  # noqa: E402
from bridge.inference import infer_state  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.planning import apply_action, load_action_templates  # noqa: E402
from bridge.planning.problem import problem_text  # noqa: E402
from bridge.recording.recording import load_recording, recording_world  # noqa: E402
from bridge.session import FULL_SESSION, SHORT_SESSION, SessionPlan, contact_phases, free_share, make_session  # noqa: E402
from bridge.sim.scene import SimConfig  # noqa: E402
from bridge.sim.simulate import ReplayResult, SimOptions  # noqa: E402
from bridge.teleop import infer_recording  # noqa: E402
from bridge.values import Pose  # noqa: E402

CACHE = REPO / "benchmarks" / "results" / "session"
PLANS = {"full": FULL_SESSION, "short": SHORT_SESSION}
TARGET_CONTACT_RTF = 20.0
REFERENCE = (SimConfig(time_step=0.001), SimOptions(sleep=False))
MAKERS = ("bridge/session.py", "bridge/enactment.py", *sorted(str(p.relative_to(REPO)) for p in (REPO / "bridge" / "bodies").glob("*.py")))
# the reference does not sleep objects: sleep.py is not part of its key
SIMULATOR = tuple(sorted(str(p.relative_to(REPO)) for p in (REPO / "bridge" / "sim").glob("*.py")
                         if p.name != "sleep.py"))


@dataclass
class Timed:
    """A replay with the clocks read at every sample (wall and CPU seconds since its first sample)."""

    result: ReplayResult
    wall: np.ndarray
    cpu: np.ndarray


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--session", choices=sorted(PLANS), default="full")
    parser.add_argument("--regenerate", action="store_true", help="make the session again even if it is cached")
    parser.add_argument("--fresh-reference", action="store_true", help="replay the 1 ms reference even if cached")
    parser.add_argument("--no-mujoco", action="store_true", help="skip the MuJoCo column")
    args = parser.parse_args(argv)
    plan = PLANS[args.session]
    odb = load_object_database()
    templates = load_action_templates(REPO / "pddl" / "templates", odb)

    folder, made_in = cached_session(plan, odb, templates, args.regenerate)
    recording = load_recording(folder)
    world = recording_world(recording, odb)
    robot = world.robot.name
    expected = world
    for step in plan.steps:
        expected = apply_action(expected, odb, templates, step.action, step.args)
    print(f"session {plan.name}: {recording.telemetry.duration:.1f} s of telemetry, {len(world.objects) - 1} objects "
          f"on the table, {len(plan.steps)} actions" + (f" (made in {made_in:.0f} s)" if made_in else " (cached)"),
          flush=True)

    # 1. the reference: full simulation at 1 ms (first: it is cached for the next run as soon as it is done)
    reference, cached = reference_run(folder, recording, odb, world, args.fresh_reference)
    phases = tuple(tuple(p) for p in reference["phases"])
    print(f"reference (1 ms, no sleeping): {reference['wall_s']:.1f} s wall" + (" (cached)" if cached else ""),
          flush=True)

    # 2. bridge, default settings
    bridge_run, to_state = timed_session(recording, odb)
    result = bridge_run.result
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        write_atomic(Path(tmp) / "problem.pddl", problem_text(to_state.inference.world, odb, "bridge-tabletop"))
    to_pddl = to_state.seconds_to_state + (time.perf_counter() - started)
    online = online_lag(result.times, bridge_run.wall, recording.telemetry.end) + to_pddl
    print(f"bridge (defaults): {result.wall_time:.1f} s wall, {result.cpu_time:.1f} s CPU", flush=True)
    bridge_facts = to_state.inference.world.facts
    rows = {"bridge": row(result, bridge_run, phases, bridge_facts, reference, expected)}
    rows["bridge"]["end_to_pddl_s"] = {"after_the_fact": round(result.wall_time + to_pddl, 3), "online": round(online, 3)}
    rows["bridge"]["awake"] = awake_figures(result)

    # 3. the full simulation at bridge's step, when bridge sleeps objects (otherwise it is the same replay)
    if result.awake:
        full_run, full_state = timed_session(recording, odb, options=SimOptions(sleep=False))
        rows["full_2ms"] = row(full_run.result, full_run, phases, full_state.inference.world.facts, reference, expected)
    else:
        rows["full_2ms"] = {"skipped": "bridge's replay reports no awake spans (sleeping not active): it is the full "
                                       "2 ms simulation"}

    # 4. MuJoCo
    rows["mujoco"] = mujoco_row(world, recording, odb, phases, reference, expected, robot)

    report = {
        "machine": platform.processor() or platform.machine(),
        "session": {"name": plan.name, "telemetry_s": round(recording.telemetry.duration, 2),
                    "objects": len(world.objects) - 1, "actions": [str(s) for s in plan.steps], "seed": plan.seed,
                    "contact_phases": len(phases), "phases": [[round(a, 2), round(b, 2)] for a, b in phases],
                    "free_share": round(free_share(phases, reference["sim_s"]), 3), "folder": str(folder.relative_to(REPO))},
        "reference": {k: reference[k] for k in ("config", "sim_s", "wall_s", "cpu_s")} | {"cached": cached},
        "bridge": rows["bridge"], "full_2ms": rows["full_2ms"], "mujoco": rows["mujoco"],
        "target_contact_rtf": TARGET_CONTACT_RTF,
    }
    if "skipped" not in rows["mujoco"]:
        report["bridge_over_mujoco"] = {"wall": round(result.wall_time / rows["mujoco"]["wall_s"], 2),
                                        "cpu": round(result.cpu_time / rows["mujoco"]["cpu_s"], 2)}
    print_report(report)
    out = REPO / "benchmarks" / "results" / ("session.json" if args.session == "full" else f"session_{args.session}.json")
    out.write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {out.relative_to(REPO)}")
    return 0


# --- the session and the reference, cached ---------------------------------------------------------------
def cached_session(plan: SessionPlan, odb, templates, regenerate: bool) -> tuple[Path, float | None]:
    """The session's recording folder, made again when its key (the plan, the world, the code that makes it)
    changed or when asked; returns the folder and the seconds it took to make (None when cached)."""
    folder = CACHE / plan.name
    key_file = CACHE / f"{plan.name}.key"
    key = digest(repr(replace(plan, world=Path(plan.world.name))), plan.world.read_bytes(), *(REPO / p for p in MAKERS))
    if not regenerate and key_file.is_file() and key_file.read_text() == key and (folder / "telemetry.csv").is_file():
        return folder, None
    print(f"making the session {plan.name} (seed {plan.seed}) into {folder.relative_to(REPO)} ...", flush=True)
    started = time.perf_counter()
    folder.parent.mkdir(parents=True, exist_ok=True)
    session = make_session(plan, folder, odb, templates, overwrite=True)
    if not session.enactment.matches:
        print("WARNING: the facts of the session's own replay differ from the plan's effects (see recording.yaml)")
    key_file.write_text(key)
    return folder, time.perf_counter() - started


def reference_run(folder: Path, recording, odb, world, fresh: bool) -> tuple[dict, bool]:
    """The 1 ms full replay's figures (facts, final poses, contact phases, times), cached beside the session."""
    config, options = REFERENCE
    key = digest(repr(REFERENCE), metadata.version("drake"),
                 *(folder / n for n in ("world.yaml", "telemetry.csv")), *(REPO / p for p in SIMULATOR))
    cache = folder.parent / f"{folder.name}.reference.json"
    if not fresh and cache.is_file():
        stored = json.loads(cache.read_text())
        if stored.get("key") == key:
            return stored, True
    session = infer_recording(recording, odb, config=config, options=options)
    result = session.replay
    figures = {"key": key, "config": "SimConfig(time_step=0.001), SimOptions(sleep=False)",
               "sim_s": result.sim_time, "wall_s": round(result.wall_time, 2), "cpu_s": round(result.cpu_time, 2),
               "facts": sorted(map(str, session.inference.world.facts)),
               "poses": {n: [*p.xyz, *p.quat] for n, p in result.final_poses.items()},
               "phases": contact_phases(result, world.robot.name)}
    cache.write_text(json.dumps(figures, indent=1) + "\n")
    return figures, False


def digest(*parts) -> str:
    h = hashlib.sha256()
    for part in parts:
        h.update(part.read_bytes() if isinstance(part, Path) else part if isinstance(part, bytes) else str(part).encode())
    return h.hexdigest()


# --- timing ------------------------------------------------------------------------------------------------
def timed_session(recording, odb, options: SimOptions = SimOptions()):
    """`bridge infer`'s replay and inference, the clocks read at every sample."""
    wall, cpu = [], []

    def stamp(t: float, end: float) -> None:
        wall.append(time.perf_counter())
        cpu.append(time.process_time())

    session = infer_recording(recording, odb, options=options, progress=stamp)
    return Timed(session.replay, np.asarray(wall) - wall[0], np.asarray(cpu) - cpu[0]), session


def span_cost(times: np.ndarray, clock: np.ndarray, spans) -> tuple[float, float]:
    """Simulated and clock seconds of the sample intervals that end inside `spans`."""
    dt, dc = np.diff(times), np.diff(clock)
    inside = np.zeros(len(dt), dtype=bool)
    for a, b in spans:
        inside |= (times[1:] >= a - 1e-9) & (times[1:] <= b + 1e-9)
    return float(dt[inside].sum()), float(dc[inside].sum())


def online_lag(times: np.ndarray, wall: np.ndarray, telemetry_end: float) -> float:
    """Seconds after the telemetry's last sample arrives until the replay's last sample is done, for a replay
    that starts with the telemetry and cannot run ahead of it (each sample waits for its telemetry)."""
    done = 0.0
    for k in range(1, len(times)):
        done = max(done, min(times[k], telemetry_end)) + (wall[k] - wall[k - 1])
    return max(0.0, done - telemetry_end)


def rtf(sim: float, clock: float) -> float | None:
    return round(sim / clock, 2) if clock > 0 else None


def row(result: ReplayResult, timed: Timed | None, phases, facts, reference: dict, expected) -> dict:
    """A replay's figures: speed overall, in the contact phases and in free motion; facts and final poses
    against the reference and the plan."""
    figures = {"sim_s": round(result.sim_time, 2), "wall_s": round(result.wall_time, 2),
               "cpu_s": round(result.cpu_time, 2), "rtf_wall": rtf(result.sim_time, result.wall_time),
               "rtf_cpu": rtf(result.sim_time, result.cpu_time),
               "max_tracking_error": round(result.max_tracking_error, 4)}
    if timed is not None:
        free = complement(phases, float(result.times[-1]))
        for label, spans in (("contact", phases), ("free", free)):
            sim, wall = span_cost(result.times, timed.wall, spans)
            _, cpu = span_cost(result.times, timed.cpu, spans)
            figures[label] = {"sim_s": round(sim, 2), "wall_s": round(wall, 2), "cpu_s": round(cpu, 2),
                              "rtf_wall": rtf(sim, wall), "rtf_cpu": rtf(sim, cpu)}
    ref_facts = set(reference["facts"])
    mine = set(map(str, facts))
    figures["facts_equal_reference"] = mine == ref_facts
    figures["facts_missing"] = sorted(ref_facts - mine)
    figures["facts_extra"] = sorted(mine - ref_facts)
    figures["facts_equal_plan"] = mine == set(map(str, expected.facts))
    worst = pose_differences(result.final_poses, reference["poses"])
    figures.update(worst)
    return figures


def complement(spans, end: float) -> tuple[tuple[float, float], ...]:
    edges, t = [], 0.0
    for a, b in spans:
        if a > t:
            edges.append((t, a))
        t = max(t, b)
    if end > t:
        edges.append((t, end))
    return tuple((a + 1e-6, b) for a, b in edges)  # open at the phase's end: its last interval is contact


def pose_differences(poses: dict[str, Pose], reference: dict[str, list[float]]) -> dict:
    """The largest final-pose difference from the reference over the objects (mm, deg) and whose it is."""
    mm, deg, who_mm, who_deg = 0.0, 0.0, None, None
    for name, values in reference.items():
        ref = Pose(tuple(values[:3]), tuple(values[3:]))
        d_mm, d_deg = 1000 * ref.translation_to(poses[name]), math.degrees(ref.rotation_to(poses[name]))
        if d_mm >= mm:
            mm, who_mm = d_mm, name
        if d_deg >= deg:
            deg, who_deg = d_deg, name
    return {"max_pose_mm": round(mm, 2), "max_pose_mm_object": who_mm, "max_pose_deg": round(deg, 2),
            "max_pose_deg_object": who_deg}


def awake_figures(result: ReplayResult) -> dict | None:
    """What the replay says it stepped with contact dynamics (None when it does not report it)."""
    if not result.awake:
        return None
    sim = sum(b - a for a, b in result.awake)
    return {"spans": len(result.awake), "sim_s": round(sim, 2), "wall_s": round(result.awake_wall, 2),
            "rtf_wall": rtf(sim, result.awake_wall)}


# --- MuJoCo ------------------------------------------------------------------------------------------------
def mujoco_row(world, recording, odb, phases, reference: dict, expected, robot: str) -> dict:
    try:
        import mujoco
    except ImportError:
        print("mujoco not installed: pip install -e .[bench]  (the MuJoCo column is skipped)")
        return {"skipped": "mujoco not installed: pip install -e .[bench]"}
    from mujoco_replay import replay

    print(f"MuJoCo {mujoco.__version__}: replaying ...", flush=True)
    run = replay(world, recording.telemetry, odb)
    result = run.result
    inferred = infer_state(world, odb, result.final_poses, result.final_contacts, result.moved,
                           result.contact_pairs(), time=result.sim_time)
    figures = {"version": mujoco.__version__,
               **row(result, Timed(result, run.stamps, run.cpu_stamps), phases, inferred.world.facts, reference,
                     expected),
               "contact_phases": len(contact_phases(result, robot))}
    return figures


# --- report --------------------------------------------------------------------------------------------------
def print_report(report: dict) -> None:
    s = report["session"]
    print(f"\n{s['name']}: {s['telemetry_s']:.0f} s, {s['objects']} objects, {len(s['actions'])} actions, "
          f"{s['contact_phases']} contact phases, robot touching nothing {100 * s['free_share']:.0f} % of the time")
    head = (f"{'replay':24s} {'wall s':>7s} {'CPU s':>7s} {'RTF':>6s} {'RTF cpu':>7s} {'contact RTF':>11s} "
            f"{'free RTF':>8s} {'facts=ref':>9s} {'facts=plan':>10s} {'max mm':>7s} {'max deg':>7s}")
    print(head)
    ref = report["reference"]
    print(f"{'full 1 ms (reference)':24s} {ref['wall_s']:7.1f} {ref['cpu_s']:7.1f} {ref['sim_s'] / ref['wall_s']:6.2f} "
          f"{ref['sim_s'] / ref['cpu_s']:7.2f}")
    for label, key in (("bridge (defaults)", "bridge"), ("full 2 ms", "full_2ms"), ("MuJoCo naive 2 ms", "mujoco")):
        r = report[key]
        if "skipped" in r:
            print(f"{label:24s} skipped: {r['skipped']}")
            continue
        contact = r.get("contact", {})
        free = r.get("free", {})
        print(f"{label:24s} {r['wall_s']:7.1f} {r['cpu_s']:7.1f} {r['rtf_wall']:6.2f} {r['rtf_cpu']:7.2f} "
              f"{_num(contact.get('rtf_wall')):>11s} {_num(free.get('rtf_wall')):>8s} {str(r['facts_equal_reference']):>9s} "
              f"{str(r['facts_equal_plan']):>10s} {r['max_pose_mm']:7.1f} {r['max_pose_deg']:7.1f}")
        if r["facts_missing"] or r["facts_extra"]:
            print(f"{'':24s} facts against the reference: missing {' '.join(r['facts_missing']) or 'none'}; "
                  f"extra {' '.join(r['facts_extra']) or 'none'}")
    b = report["bridge"]
    print(f"bridge: end of telemetry -> PDDL problem written: {b['end_to_pddl_s']['online']:.2f} s on-line "
          f"(replay alongside the telemetry), {b['end_to_pddl_s']['after_the_fact']:.1f} s after the fact")
    if b["awake"]:
        a = b["awake"]
        print(f"bridge: awake (contact dynamics) {a['sim_s']:.1f} s of {b['sim_s']:.0f} s in {a['spans']} spans, "
              f"RTF {a['rtf_wall']} there")
    else:
        print("bridge: the replay reports no awake spans (sleeping objects not active); the contact RTF is over the "
              "reference's contact phases")
    print(f"contact phases at >= {TARGET_CONTACT_RTF:.0f}x real time: "
          f"{'yes' if (b.get('contact', {}).get('rtf_wall') or 0) >= TARGET_CONTACT_RTF else 'no'}")
    m = report["mujoco"]
    if "skipped" not in m:
        ratio = report["bridge_over_mujoco"]
        print(f"bridge / MuJoCo wall time: {ratio['wall']:.1f} (CPU: {ratio['cpu']:.1f}); "
              f"bridge faster than MuJoCo's naive replay: {'yes' if ratio['wall'] < 1 else 'no'}")
        print(f"MuJoCo {m['version']}: worst joint tracking {m['max_tracking_error']:.3f} rad (bridge: "
              f"{b['max_tracking_error']:.3f}), "
              f"{m['contact_phases']} contact phases, final poses within {m['max_pose_mm']:.1f} mm / "
              f"{m['max_pose_deg']:.1f} deg of the reference ({m['max_pose_mm_object']}), facts "
              f"{'equal' if m['facts_equal_reference'] else 'differ'}")


def _num(value) -> str:
    return "-" if value is None else f"{value:.2f}"


if __name__ == "__main__":
    sys.exit(main())
