"""The `bridge` command: parses arguments and calls one function per command; nothing else lives here."""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Callable, Sequence

from .errors import BridgeError

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_TEMPLATES = REPO_ROOT / "pddl"


# --- shared loading ---------------------------------------------------------------------------
def _odb(args):
    from .odb import load_object_database, parse_dataset_options

    return load_object_database(args.odb, datasets=parse_dataset_options(args.dataset or ()))


def _templates(args, odb):
    from .planning.templates import load_action_templates

    return load_action_templates(Path(args.templates) / "templates", odb)


def _domain_name(args) -> str:
    from .planning.templates import load_domain_settings

    return load_domain_settings(Path(args.templates)).name


# --- commands -----------------------------------------------------------------------------------
def cmd_check(args) -> int:
    from .sim.shapes import mass_properties

    odb = _odb(args)
    templates = _templates(args, odb)
    concrete = odb.concrete_types()
    print(f"object database {odb.root}: {len(odb.types)} types ({len(concrete)} concrete), "
          f"{len(odb.predicates)} predicates, PDDL types: {', '.join(sorted(odb.pddl_types))}")
    for name in concrete:  # mass properties of every usable type, so a broken mesh shows now
        t = odb.types[name]
        if t.geometry is not None and t.geometry.unresolved is None and not t.fixed and not t.is_robot:
            mass_properties(odb, name)
    unresolved = sorted(n for n in concrete if odb.types[n].geometry is not None and odb.types[n].geometry.unresolved)
    if unresolved:
        print(f"  not checked (dataset not found): {', '.join(unresolved)}")
    print(f"action templates {Path(args.templates) / 'templates'}: {', '.join(sorted(templates))}")
    print("ok")
    return 0


def cmd_export(args) -> int:
    from .planning.problem import export_pddl
    from .world import load_world_state

    odb = _odb(args)
    world = load_world_state(args.world, odb)
    templates = _templates(args, odb)
    out = Path(args.out)
    domain_path, problem_path = export_pddl(world, odb, templates, out, domain_name=_domain_name(args), goal=args.goal)
    print(f"wrote {domain_path} and {problem_path}")
    return 0


def cmd_diff(args) -> int:
    from .diff import diff_world_problem, diff_worlds
    from .planning.problem import read_problem
    from .world import load_world_state

    odb = _odb(args)
    before = load_world_state(args.a, odb)
    if str(args.b).endswith(".pddl"):
        diff = diff_world_problem(before, read_problem(Path(args.b), odb))
    else:
        diff = diff_worlds(before, load_world_state(args.b, odb),
                           translation_threshold=args.translation, rotation_threshold_deg=args.rotation)
    print(json.dumps(diff.to_json(), indent=2) if args.json else diff.text())
    return 0


def cmd_apply(args) -> int:
    from .diff import diff_worlds
    from .planning.apply import apply_action
    from .world import load_world_state, save_world_state

    odb = _odb(args)
    world = load_world_state(args.world, odb)
    after = apply_action(world, odb, _templates(args, odb), args.action, list(args.args))
    print(diff_worlds(world, after).text())
    if args.out:
        save_world_state(after, args.out)
        print(f"wrote {args.out}")
    return 0


class Progress:
    """A one-line progress bar on stderr for long replays (silent when stderr is not a terminal)."""

    def __init__(self, label: str):
        self.label, self.last = label, -1
        self.enabled = sys.stderr.isatty()

    def __call__(self, done: float, total: float) -> None:
        percent = int(100 * done / total) if total else 100
        if self.enabled and percent != self.last:
            self.last = percent
            print(f"\r{self.label}: {percent:3d}% ({done:.1f} / {total:.1f} s simulated)", end="", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.enabled and self.last >= 0:
            print(file=sys.stderr)


def _replay_setting(args, world, telemetry, odb):
    """What a replay of one recording runs with (a `SceneSetting`): the diagnosed scene file (--scene: extra
    geometry, corrected poses, values, clock), then a fitted parameter file (--params) on top."""
    from dataclasses import replace

    from .diagnosis.scenefile import SceneSetting, load_scene_file, replay_setting

    setting = SceneSetting(world, None, telemetry, (), ())
    if getattr(args, "scene", None):
        setting = replay_setting(load_scene_file(args.scene), world, telemetry, odb)
    if getattr(args, "params", None):
        from .fit.params import load_param_file, scene_setting

        params, telemetry = scene_setting(load_param_file(args.params), setting.world, setting.telemetry, odb,
                                          base=setting.params)
        setting = replace(setting, params=params, telemetry=telemetry)
    return setting


def _session(recording_path, odb, args, *, label: str, events=None):
    from .recording.recording import load_recording
    from .sim.scene import build_scene
    from .teleop import run_session
    from .world import load_world_state

    recording = load_recording(recording_path)
    before = load_world_state(recording.world_path, odb)
    setting = _replay_setting(args, before, recording.telemetry, odb)
    scene = build_scene(setting.world, odb, extras=setting.extras) if setting.extras else None
    progress = Progress(label)
    try:
        return recording, run_session(setting.world, setting.telemetry, odb, scene=scene, params=setting.params,
                                      event_period=args.event_period if events else None, on_event=events,
                                      progress=progress)
    finally:
        progress.close()


def _write_outputs(session, odb, args, world_out: Path, problem_out: Path | None) -> None:
    from .planning.problem import problem_text
    from .files import write_atomic
    from .world import save_world_state

    save_world_state(session.inference.world, world_out)
    if problem_out is not None:
        write_atomic(problem_out, problem_text(session.inference.world, odb, _domain_name(args)))


def _report_failures(session) -> int:
    for failure in session.inference.failures:
        print(f"warning: {failure}", file=sys.stderr)
    return 2 if session.inference.failures else 0


def cmd_infer(args) -> int:
    from .diff import diff_worlds
    from .teleop import json_lines

    odb = _odb(args)
    events = json_lines(sys.stdout) if args.events else None
    recording, session = _session(args.recording, odb, args, label=f"replaying {Path(args.recording).name}", events=events)
    world_out = Path(args.world_out or Path(args.recording) / "world_after.yaml")
    problem_out = Path(args.problem_out) if args.problem_out else world_out.with_name("problem_after.pddl")
    _write_outputs(session, odb, args, world_out, problem_out)
    out = sys.stderr if args.events else sys.stdout
    print(diff_worlds(session.before, session.inference.world).text(), file=out)
    r = session.replay
    print(f"replayed {r.sim_time:.1f} s at {r.realtime_factor:.1f}x real time; state inferred in "
          f"{session.seconds_to_state * 1000:.0f} ms; wrote {world_out} and {problem_out}", file=out)
    return _report_failures(session)


def cmd_demo(args) -> int:
    from .diff import diff_worlds

    odb = _odb(args)
    folders = sorted(p for p in Path(args.recordings).iterdir() if (p / "world.yaml").is_file())
    if not folders:
        raise BridgeError("no recordings (folders with world.yaml) found", source=str(args.recordings))
    out_root = Path(args.out)
    status = 0
    for folder in folders:
        _, session = _session(folder, odb, args, label=folder.name)
        out = out_root / folder.name
        _write_outputs(session, odb, args, out / "world_after.yaml", out / "problem_after.pddl")
        r = session.replay
        print(f"== {folder.name}: {r.sim_time:.1f} s replayed at {r.realtime_factor:.1f}x real time, "
              f"moved: {', '.join(r.moved) or 'nothing'}")
        print(diff_worlds(session.before, session.inference.world).text())
        status = max(status, _report_failures(session))
    print(f"wrote the inferred world states and PDDL problems under {out_root}")
    return status


def cmd_view(args) -> int:
    from .recording.recording import load_recording
    from .sim.viewer import write_replay_html
    from .world import load_world_state

    odb = _odb(args)
    recording = load_recording(args.recording)
    world = load_world_state(recording.world_path, odb)
    out = Path(args.out or Path(args.recording) / "replay.html")
    setting = _replay_setting(args, world, recording.telemetry, odb)
    write_replay_html(setting.world, setting.telemetry, odb, out, observations=recording.observations,
                      params=setting.params, extras=setting.extras)
    print(f"wrote {out} (open it in a browser)")
    return 0


def cmd_fit(args) -> int:
    from .fit.executors import make_executor
    from .fit.fit import fit_parameters, result_summary
    from .fit.params import load_param_file
    from .fit.report import table1, write_report
    from .fit.rollout import default_spec
    from .fit.trials import load_trials

    odb = _odb(args)
    trials = load_trials(args.recordings, odb, max_duration=args.max_duration)
    if args.scene:  # fit on top of the model bridge diagnose found
        from .diagnosis.scenefile import load_scene_file, trials_under

        trials = trials_under(load_scene_file(args.scene), trials, odb)
    spec = load_param_file(args.params) if args.params else default_spec(trials, odb)
    out = Path(args.out)
    print(f"bridge fit: {len(trials)} trial(s); free parameters: {', '.join(spec.names) or 'none'}", file=sys.stderr)
    with make_executor(args.executor, odb, workers=args.workers, scheduler=args.scheduler) as executor:
        result = fit_parameters(trials, spec, odb=odb, optimizer=args.optimizer, seed=args.seed,
                                generations=args.generations, popsize=args.popsize, executor=executor,
                                hold_out=args.hold_out, checkpoint=out, resume=args.resume, progress=_fit_progress)
    files = write_report(result, out, trials=trials, odb=odb)
    print(table1(result))
    print(result_summary(result))
    print(f"wrote {', '.join(str(f) for f in files.values())}")
    return 0


def _fit_progress(p) -> None:
    print(f"generation {p.generation}/{p.max_generations}: best e {p.best_e:.6f} (this generation {p.generation_best_e:.6f}), "
          f"{p.evaluations} candidates, {p.simulations} simulations, {p.failures} failed, {p.elapsed:.1f} s",
          file=sys.stderr, flush=True)


def cmd_diagnose(args) -> int:
    from .diagnosis.pipeline import diagnose_paths, summary_text

    run = diagnose_paths(args.recordings, _odb(args), args.out, held_out=args.hold_out, workers=args.workers,
                         effects=args.effects.split(",") if args.effects else None, max_duration=args.max_duration)
    print(summary_text(run))
    print(f"wrote {', '.join(str(f) for f in run.files.values())}")
    return 0


def cmd_prove(args) -> int:
    from .diagnosis.prove import run_proof

    proof = run_proof(args.out, _odb(args), size=args.size, workers=args.workers,
                      log=lambda m: print(m, file=sys.stderr, flush=True))
    print(proof.text())
    print(f"wrote {Path(args.out) / 'proof.json'} and {Path(args.out) / 'proof.md'}")
    return 0


def cmd_act(args) -> int:
    from .enactment import make_recording

    odb = _odb(args)
    recording = make_recording(Path(args.world), args.action, list(args.args), Path(args.out), odb, _templates(args, odb))
    print(f"wrote recording {recording.folder} ({recording.telemetry.duration:.1f} s of telemetry)")
    return 0


COMMANDS: dict[str, tuple[Callable, str]] = {
    "infer": (cmd_infer, "replay a recording in Drake and infer the world state after it"),
    "demo": (cmd_demo, "run the paper's four trials and print what changed in each"),
    "view": (cmd_view, "write a self-contained HTML replay of a recording (observed poses as ghosts)"),
    "act": (cmd_act, "make a recording from an action template's body"),
    "fit": (cmd_fit, "fit simulation parameters (friction, mass, ...) to recordings with observed poses"),
    "diagnose": (cmd_diagnose, "locate where simulation and recordings differ, name the missing physics, model it"),
    "prove": (cmd_prove, "conceal each effect in generated recordings and diagnose them blind (confusion matrix)"),
    "check": (cmd_check, "validate the object database and the action templates"),
    "export": (cmd_export, "write the PDDL domain and problem of a world state"),
    "diff": (cmd_diff, "compare two world states (or a world state and a PDDL problem)"),
    "apply": (cmd_apply, "apply a ground action template to a world state"),
}


def _model_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scene", default=None, metavar="FILE", help="diagnosed scene file (scene.yaml from bridge diagnose)")
    p.add_argument("--params", default=None, metavar="FILE", help="fitted parameter file (params.yaml from bridge "
                   "fit); with --scene, its values go on top of the scene's")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="bridge", description="Keep a robot's symbolic world state true while a person teleoperates it: "
        "replay its telemetry in Drake, infer the facts, write PDDL, fit and diagnose the physics.")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--odb", default=None, help="object database folder (default: the bundled odb/)")
    common.add_argument("--templates", default=str(DEFAULT_TEMPLATES), help="folder with domain.yaml and templates/ (default: %(default)s)")
    common.add_argument("--dataset", action="append", metavar="NAME=PATH",
                        help="root of a dataset named in dataset:// mesh paths, e.g. mit-push=../shared/datasets/mit-push")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def add(name: str) -> argparse.ArgumentParser:
        func, text = COMMANDS[name]
        p = sub.add_parser(name, parents=[common], help=text, description=text)
        p.set_defaults(func=func)
        return p

    add("check")
    p = add("export")
    p.add_argument("world", help="world-state YAML")
    p.add_argument("--out", default=".", help="folder for domain.pddl and problem.pddl (default: current folder)")
    p.add_argument("--goal", default=None, help="PDDL goal, e.g. '(and (on big_box tray))' (default: the world's goal)")
    p = add("diff")
    p.add_argument("a", help="world state before")
    p.add_argument("b", help="world state after, or a PDDL problem (.pddl)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--translation", type=float, default=0.01, help="moved when translated more than this (m, default %(default)s)")
    p.add_argument("--rotation", type=float, default=5.0, help="moved when turned more than this (deg, default %(default)s)")
    p = add("apply")
    p.add_argument("world", help="world-state YAML")
    p.add_argument("action", help="action template name, e.g. pick")
    p.add_argument("args", nargs="*", help="the action's arguments (object names)")
    p.add_argument("--out", default=None, help="write the successor world state here")
    p = add("infer")
    p.add_argument("recording", help="recording folder (world.yaml, telemetry, optional observed.csv)")
    p.add_argument("--world-out", default=None, help="inferred world state (default: RECORDING/world_after.yaml)")
    p.add_argument("--problem-out", default=None, help="PDDL problem of it (default: beside --world-out)")
    p.add_argument("--events", action="store_true", help="print predicate changes as JSON lines while replaying")
    p.add_argument("--event-period", type=float, default=0.1, help="simulated seconds between on-line inferences (default %(default)s)")
    _model_args(p)
    p = add("demo")
    p.add_argument("--recordings", default=str(REPO_ROOT / "demo" / "recordings"), help="folder of recordings (default: the bundled trials)")
    p.add_argument("--out", default="out/demo", help="where to write inferred states (default: %(default)s)")
    _model_args(p)
    p = add("view")
    p.add_argument("recording", help="recording folder")
    p.add_argument("--out", default=None, help="HTML file (default: RECORDING/replay.html)")
    _model_args(p)
    p = add("act")
    p.add_argument("world", help="world state before the action")
    p.add_argument("action", help="action template, e.g. push_over")
    p.add_argument("args", nargs="*", help="the action's arguments")
    p.add_argument("--out", required=True, help="recording folder to write")
    p = add("fit")
    p.add_argument("recordings", nargs="+", metavar="RECORDING",
                   help="recording folders (with observed.csv), MIT .h5 files, or folders of .h5 files")
    p.add_argument("--out", required=True, metavar="DIR", help="report folder (params.yaml, fit.json, table1.md, "
                   "figures) and checkpoint.json")
    p.add_argument("--params", default=None, metavar="FILE", help="parameter file saying what to fit (default: "
                   "the friction of the moved objects and of what they touch)")
    p.add_argument("--scene", default=None, metavar="FILE", help="fit on top of a diagnosed scene file (scene.yaml "
                   "from bridge diagnose: its extra geometry, corrections and values stay fixed)")
    p.add_argument("--optimizer", choices=("cmaes", "es"), default="cmaes", help="default: %(default)s")
    p.add_argument("--generations", type=int, default=30, help="at most this many (default %(default)s; stops "
                   "earlier when the best error stops improving)")
    p.add_argument("--popsize", type=int, default=None, help="candidates per generation (default: cmaes 4 + 3 ln D, "
                   "es 10 D as in the paper)")
    p.add_argument("--seed", type=int, default=0, help="seeds the optimiser and the hold-out split (default %(default)s)")
    p.add_argument("--executor", choices=("process", "dask", "serial"), default="process", help="default: %(default)s")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: one per CPU)")
    p.add_argument("--scheduler", default=None, metavar="ADDR", help="a dask scheduler's address (with --executor dask)")
    p.add_argument("--hold-out", type=int, default=None, metavar="N", help="trials kept out of the fit to test it "
                   "(default: 25%% when there are 4 or more)")
    p.add_argument("--resume", action="store_true", help="continue from DIR/checkpoint.json")
    p.add_argument("--max-duration", type=float, default=None, metavar="S", help="use only the first S seconds of "
                   "each MIT push")
    p = add("diagnose")
    p.add_argument("recordings", nargs="+", metavar="RECORDING",
                   help="recording folders (with observed.csv), MIT .h5 files, or folders of .h5 files")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for diagnosis.json, report.md, scene.yaml, plots")
    p.add_argument("--hold-out", type=int, default=None, metavar="N", help="recordings kept out of the fit to check "
                   "it (default: a quarter when there are 4 or more)")
    p.add_argument("--effects", default=None, metavar="A,B", help="only these effects of the catalog (default: all)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: up to 2)")
    p.add_argument("--max-duration", type=float, default=None, metavar="S", help="use only the first S seconds of "
                   "each MIT push")
    p = add("prove")
    p.add_argument("--size", choices=("small", "full"), default="small", help="small: one case per effect (CI); "
                   "full: three magnitudes, two seeds (default: %(default)s)")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for the generated recordings and proof.json")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: up to 2)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BridgeError as exc:
        print(f"bridge {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"bridge {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug, not bad input: still one line, with the way to the traceback
        if os.environ.get("BRIDGE_DEBUG"):
            raise
        print(f"bridge {args.command}: internal error: {type(exc).__name__}: {exc} (set BRIDGE_DEBUG=1 for the traceback)",
              file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
