"""The commands of the `bridge` command line, one function each: they load what the arguments name, call the
library, print, and return an exit status. `run` turns any bridge error into one line and a non-zero exit.
"""
from __future__ import annotations

import json
import os
import signal
import sys
import threading
from contextlib import ExitStack, suppress
from pathlib import Path
from typing import Callable

from .errors import BridgeError


def _terminate(signum, frame):
    raise KeyboardInterrupt  # SIGTERM ends a command the way Ctrl-C does: outputs as a set, locks released


def run(command: Callable, args) -> int:
    """Run one command; bad input is one line on stderr (exit 1), never a traceback."""
    on_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if on_main else None
    try:
        with ExitStack() as claimed:  # the outputs the command claimed (_claim): locked until it ends
            args._claimed = claimed
            return int(command(args) or 0)
    except BrokenPipeError:  # `bridge ... | head`: the reader left; nothing more to say to it
        with suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except BridgeError as exc:
        print(f"bridge {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"bridge {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug, not bad input: still one line, with the way to the traceback
        if os.environ.get("BRIDGE_DEBUG"):
            raise
        print(f"bridge {args.command}: internal error: {type(exc).__name__}: {exc} (set BRIDGE_DEBUG=1 for the "
              "traceback)", file=sys.stderr)
        return 3
    finally:
        if on_main:
            signal.signal(signal.SIGTERM, previous)


# --- shared loading ---------------------------------------------------------------------------
def _odb(args):
    from .odb import load_object_database, parse_dataset_options

    return load_object_database(args.odb, datasets=parse_dataset_options(args.dataset or ()))


def _templates(args, odb):
    from .planning.templates import load_action_templates

    return load_action_templates(Path(args.templates) / "templates", odb)


def _domain_name(args) -> str:
    """The domain's name from domain.yaml, read once per command (infer reads it before replaying, so a broken
    domain.yaml is refused before the work)."""
    from .planning.templates import load_domain_settings

    if getattr(args, "_domain", None) is None:
        args._domain = load_domain_settings(Path(args.templates)).name
    return args._domain


# --- outputs ------------------------------------------------------------------------------------
OUT_ROOT = Path("out")  # default outputs go under ./out, never into an input folder


def _claim(args, files=(), folders=(), *, replaced=(), inputs=()) -> None:
    """Check every output before the long work and lock its folder until the command ends (see
    `bridge.files.claim_outputs`); called from outside `run`, only the checks are made."""
    from .files import claim_outputs

    claim = claim_outputs(files, folders, replaced=replaced, inputs=inputs)
    stack = getattr(args, "_claimed", None)
    if stack is None:
        with claim:
            return
    stack.enter_context(claim)


def _default_out(recording) -> Path:
    """out/NAME, NAME the recording folder's name or the push file's stem: where `infer` and `view` write when
    not told."""
    path = Path(recording).resolve()
    return OUT_ROOT / ((path.stem if path.is_file() else path.name) or "recording")


def _infer_outputs(args) -> tuple[Path, Path]:
    """`infer`'s world state and problem (default: out/NAME/world_after.yaml and problem_after.pddl), claimed."""
    from .planning.problem import uncertain_path

    world_out = Path(args.world_out) if args.world_out else _default_out(args.recording) / "world_after.yaml"
    problem_out = Path(args.problem_out) if args.problem_out else world_out.with_name("problem_after.pddl")
    _claim(args, [world_out, problem_out, uncertain_path(problem_out)], inputs=_model_inputs(args, args.recording))
    return world_out, problem_out


def _model_inputs(args, recording=None) -> list[Path]:
    """The files a replay reads (an output must not overwrite one)."""
    from .recording.recording import input_paths

    files = [Path(f) for f in (getattr(args, "scene", None), getattr(args, "params", None)) if f]
    return files + (list(input_paths(recording)) if recording is not None else [])


# --- commands -----------------------------------------------------------------------------------
def check(args) -> int:
    from .check import check_database, check_domain, check_inputs

    odb = _odb(args)  # its SIEs are made with their parameters as it is read
    inputs = check_inputs(args.paths, odb, scene=args.scene, params=args.params)  # a scene file alone: refused now
    print(check_database(odb), flush=True)
    print(check_domain(Path(args.templates), odb), flush=True)
    for line in inputs:
        print(line, flush=True)
    print("ok")
    return 0


def export(args) -> int:
    from .planning.problem import export_pddl, uncertain_facts, uncertain_path
    from .planning.templates import load_domain_settings
    from .world import load_world_state

    odb = _odb(args)
    world = load_world_state(args.world, odb)
    templates = _templates(args, odb)
    out = Path(args.out)
    _claim(args, [out / "domain.pddl", out / "problem.pddl", uncertain_path(out / "problem.pddl")],
           inputs=[args.world])
    domain_path, problem_path = export_pddl(world, odb, templates, out, settings=load_domain_settings(Path(args.templates)),
                                            goal=args.goal, min_probability=args.min_probability)
    uncertain = uncertain_facts(world, args.min_probability)
    print(f"wrote {domain_path} and {problem_path}"
          + (f"; {len(uncertain)} uncertain fact(s) left out, listed in {uncertain_path(problem_path)}"
             if world.samples else ""))
    return 0


def diff(args) -> int:
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


def apply(args) -> int:
    from .diff import diff_worlds
    from .planning.apply import apply_action
    from .world import load_world_state, save_world_state

    odb = _odb(args)
    if args.out:
        _claim(args, [args.out])
    world = load_world_state(args.world, odb)
    after = apply_action(world, odb, _templates(args, odb), args.action, list(args.args))
    print(diff_worlds(world, after).text())
    if args.out:
        save_world_state(after, args.out)
        print(f"wrote {args.out}")
    return 0


REPLAY_QUIET = 30.0  # s: off a terminal, a replay shorter than this prints no progress line (a log stays quiet)


def _replay_progress(label: str):
    """Progress of one replay, in simulated seconds (a bar on a terminal, plain lines in a log)."""
    from .progress import Progress

    return Progress(label, unit=" s simulated", number=".1f", delay=REPLAY_QUIET)


def _is_push_file(path) -> bool:
    from .rollout.trials import H5_SUFFIXES

    return Path(path).suffix.lower() in H5_SUFFIXES and not Path(path).is_dir()


class _Source:
    """What a command replays: a recording folder's, or an MIT push file's world, telemetry and observations."""

    def __init__(self, path, odb, args):
        self.path = Path(path)
        shape = getattr(args, "shape", None)
        if _is_push_file(path):
            from .rollout import load_trials

            trial = load_trials([path], odb, shape=shape)[0]
            self.name, self.world, self.telemetry = trial.name, trial.world, trial.telemetry
            self.observations = trial.observations
        else:
            from .recording.recording import load_recording, recording_world

            if shape is not None:
                raise BridgeError(f"--shape {shape} names the shape pushed in an MIT .h5 file, but {path} is not one")
            recording = load_recording(path)
            self.name, self.telemetry = recording.name, recording.telemetry
            self.world = recording_world(recording, odb)  # observed objects and telemetry checked against it
            self.observations = recording.observations


def _rollout(recording, odb, args):
    """A recording's rollout under the diagnosed scene file (--scene: corrected poses, extra geometry, values,
    clock), then a fitted parameter file (--params) on top; both are parameter files, every target checked
    against the recording's world."""
    from .params import apply_model, check_values, load_param_file, replay_model
    from .rollout import Rollout

    rollout = recorded = Rollout(recording.world, recording.telemetry, name=recording.name)
    for option in ("scene", "params"):
        path = getattr(args, option, None)
        if path:
            parameters = load_param_file(path)
            check_values(parameters, [recorded], odb)  # against the recording, before anything is simulated
            rollout = apply_model(replay_model(parameters), rollout, odb, source=path)
    return rollout


def _sim_options(args):
    from .sim.simulate import SimOptions

    return SimOptions(sleep=getattr(args, "sleep", True))


def _session(recording_path, odb, args, *, label: str, events=None):
    from .teleop import run_session

    recording = _Source(recording_path, odb, args)
    rollout = _rollout(recording, odb, args)
    progress = _replay_progress(label)
    try:
        return recording, run_session(rollout, odb, options=_sim_options(args),
                                      event_period=args.event_period if events else None,
                                      on_event=events, progress=progress)
    finally:
        progress.close()


def _write_outputs(world, odb, args, world_out: Path, problem_out: Path | None) -> None:
    """The world state after, and its PDDL problem (with a world's fact probabilities: the believed facts, and
    the uncertain ones in comments and beside it as JSON), published as one set: an interrupt leaves the old
    files or the new ones, never a new world state beside an old problem."""
    from .files import write_set
    from .planning.problem import problem_text, uncertain_path, uncertain_text
    from .probability import DEFAULT_MIN_PROBABILITY
    from .world import world_text

    files = {world_out: world_text(world)}
    if problem_out is not None:
        threshold = getattr(args, "min_probability", DEFAULT_MIN_PROBABILITY)
        files[problem_out] = problem_text(world, odb, _domain_name(args), min_probability=threshold)
        files[uncertain_path(problem_out)] = uncertain_text(world, threshold)  # None: a stale one is removed
    write_set(files)


def _sampled(recording_path, odb, args, *, label: str, events=None):
    """The recording replayed as it is and `--samples` times with parameters drawn from the uncertainty of the
    --scene / --params files (entries with a std), or else from the object database's ranges."""
    from .params import load_param_file
    from .progress import Progress
    from .rollout import make_executor
    from .uncertainty import parameters_from_file, sample_session

    recording = _Source(recording_path, odb, args)
    rollout = _rollout(recording, odb, args)
    drawn = [u for option in ("scene", "params") if getattr(args, option, None)
             for u in parameters_from_file(load_param_file(getattr(args, option)), rollout.world, odb)]
    time_limit = getattr(args, "time_limit", None)
    progress = _replay_progress(label)
    samples = Progress("sample", total=args.samples, time_limit=time_limit)
    try:
        with make_executor(args.executor, odb, workers=args.workers) as executor:
            return recording, sample_session(rollout, odb, args.samples, executor=executor, parameters=drawn or None,
                                             seed=args.seed, options=_sim_options(args), event_period=args.event_period if events else None,
                                             on_event=events, progress=progress, sample_progress=samples,
                                             time_limit=time_limit)
    finally:
        progress.close()
        samples.close()


def _report_failures(session) -> int:
    for failure in session.inference.failures:
        print(f"warning: {failure}", file=sys.stderr)
    return 2 if session.inference.failures else 0


def infer(args) -> int:
    from .diff import diff_worlds
    from .teleop import json_lines

    from .probability import check_min_probability

    odb = _odb(args)
    check_min_probability(args.min_probability)
    _domain_name(args)
    if args.time_limit is not None and not args.samples:
        raise BridgeError("--time-limit bounds the sampled replays: it needs --samples N")
    events = json_lines(sys.stdout) if args.events else None
    world_out, problem_out = _infer_outputs(args)
    label = f"replaying {Path(args.recording).name}"
    sampled = None
    if args.samples:
        from .uncertainty import probability_event, spread_text

        recording, sampled = _sampled(args.recording, odb, args, label=label, events=events)
        session, world = sampled.nominal, sampled.world
        if events:
            events(probability_event(sampled))
    else:
        recording, session = _session(args.recording, odb, args, label=label, events=events)
        world = session.inference.world
    _write_outputs(world, odb, args, world_out, problem_out)
    out = sys.stderr if args.events else sys.stdout
    print(diff_worlds(session.before, world).text(), file=out)
    r = session.replay
    print(f"replayed {r.sim_time:.1f} s at {r.realtime_factor:.1f}x real time; state inferred in "
          f"{session.seconds_to_state * 1000:.0f} ms; wrote {world_out} and {problem_out}", file=out)
    if sampled is not None:
        print(spread_text(sampled), file=out)
    return _report_failures(session)


def demo(args) -> int:
    from .diff import diff_worlds

    odb = _odb(args)
    folders = sorted(p for p in Path(args.recordings).iterdir() if (p / "world.yaml").is_file())
    if not folders:
        raise BridgeError("no recordings (folders with world.yaml) found", source=str(args.recordings))
    out_root = Path(args.out)
    _claim(args, folders=[out_root / folder.name for folder in folders], inputs=_model_inputs(args))
    status = 0
    for folder in folders:
        _, session = _session(folder, odb, args, label=folder.name)
        out = out_root / folder.name
        _write_outputs(session.inference.world, odb, args, out / "world_after.yaml", out / "problem_after.pddl")
        r = session.replay
        print(f"== {folder.name}: {r.sim_time:.1f} s replayed at {r.realtime_factor:.1f}x real time, "
              f"moved: {', '.join(r.moved) or 'nothing'}")
        print(diff_worlds(session.before, session.inference.world).text())
        status = max(status, _report_failures(session))
    print(f"wrote the inferred world states and PDDL problems under {out_root}")
    return status


def view(args) -> int:
    from .sim.viewer import write_replay_html

    odb = _odb(args)
    out = Path(args.out) if args.out else _default_out(args.recording) / "replay.html"
    _claim(args, [out], inputs=_model_inputs(args, args.recording))
    recording = _Source(args.recording, odb, args)
    r = _rollout(recording, odb, args)
    spread = ()
    if args.samples:  # where the objects end under the drawn parameters, as ghosts
        spread = tuple(p for p in _sampled(args.recording, odb, args, label="sampling")[1].finals if p is not None)
    write_replay_html(r.world, r.telemetry, odb, out, observations=recording.observations, values=r.values,
                      extras=r.extras, hooks=r.hooks, spread=spread, sleep=args.sleep)
    print(f"wrote {out} (open it in a browser)" + (f"; {len(spread)} sampled final poses as ghosts" if spread else ""))
    return 0


def fit(args) -> int:
    from dataclasses import replace

    from .fit.evaluate import default_spec
    from .fit.fit import fit_parameters, result_summary
    from .fit.report import table1, write_report
    from .params import apply_model, check_targets, check_values, load_param_file, replay_model
    from .rollout import Rollout, load_trials, make_executor

    odb = _odb(args)
    _claim(args, folders=[args.out], inputs=[f for f in (args.params, args.scene) if f])
    trials = load_trials(args.recordings, odb, max_duration=args.max_duration, shape=args.shape)
    recorded = [Rollout(t.world, t.telemetry, name=t.name) for t in trials]
    if args.scene:  # fit on top of the model bridge diagnose found: its settings start every replay
        scene = load_param_file(args.scene)
        base = replay_model(scene)
        check_values(scene, recorded, odb)
        for t in trials:  # every target must name something in every recording
            apply_model(base, Rollout(t.world, t.telemetry), odb, source=args.scene)
        trials = [replace(t, base=base) for t in trials]
    spec = load_param_file(args.params) if args.params else default_spec(trials, odb)
    check_targets(spec, [t.world for t in trials], odb)  # refused before anything is printed
    check_values(spec, recorded, odb)
    out = Path(args.out)
    print(f"bridge fit: {len(trials)} trial(s); free parameters: {', '.join(spec.names) or 'none'}", file=sys.stderr)
    report = _FitProgress(args.time_limit)
    try:
        with make_executor(args.executor, odb, workers=args.workers, scheduler=args.scheduler) as executor:
            result = fit_parameters(trials, spec, odb=odb, optimizer=args.optimizer, seed=args.seed,
                                    generations=args.generations, popsize=args.popsize, executor=executor,
                                    hold_out=args.hold_out, checkpoint=out, resume=args.resume, progress=report,
                                    time_limit=args.time_limit)
    finally:
        report.close()
    files = write_report(result, out, trials=trials, odb=odb)
    print(table1(result))
    print(result_summary(result))
    print(f"wrote {', '.join(str(f) for f in files.values())}")
    return 0


class _FitProgress:
    """A fit's generations as a progress bar (plain lines off a terminal), and after the first one an estimate
    of the whole fit's time."""

    def __init__(self, time_limit: float | None):
        from .progress import Progress

        self.time_limit = time_limit
        self.bar = Progress("generation", time_limit=time_limit)
        self.estimated = False

    def __call__(self, p) -> None:
        from .progress import duration_text

        self.bar(p.generation, p.max_generations,
                 status=f"best e {p.best_e:.6f} (this generation {p.generation_best_e:.6f}), {p.evaluations} "
                        f"candidates, {p.simulations} simulations, {p.failures} failed")
        if not self.estimated:
            self.estimated = True
            left = p.max_generations - p.generation
            if left > 0 and p.generation == 1:  # (a resumed fit starts later: its bar estimates from its pace)
                each = p.elapsed  # scoring the start values included: an estimate on the safe side
                text = (f"bridge fit: the first generation took {duration_text(each)}; the {left} left take about "
                        f"{duration_text(each * left)} more at most (the fit stops earlier when the best error stops "
                        "improving)")
                if self.time_limit is not None:
                    text += f"; the time limit stops it after {duration_text(self.time_limit)}"
                else:
                    text += "; --time-limit SECONDS bounds it"
                self.bar.write(text)

    def close(self) -> None:
        self.bar.close()


def diagnose(args) -> int:
    from .diagnosis.pipeline import diagnose_paths, summary_text
    from .progress import Progress

    _claim(args, folders=[args.out])
    progress = Progress("diagnosis step", time_limit=args.time_limit)
    try:
        run = diagnose_paths(args.recordings, _odb(args), args.out, held_out=args.hold_out, workers=args.workers,
                             effects=[e.strip() for e in args.effects.split(",")] if args.effects else None,
                             max_duration=args.max_duration, shape=args.shape, time_limit=args.time_limit,
                             time_step=args.time_step, log=progress.write, progress=progress,
                             quasi_static=not args.own_speed, contact=args.fit_contact)
    finally:
        progress.close()
    print(summary_text(run))
    print(f"wrote {', '.join(str(f) for f in run.files.values())}")
    return 0


def prove(args) -> int:
    from .progress import Progress
    from .prove.proof import run_proof

    _claim(args, folders=[args.out])
    progress = Progress("case", time_limit=args.time_limit)
    try:
        proof = run_proof(args.out, _odb(args), size=args.size, world=args.world, workers=args.workers,
                          log=progress.write,
                          progress=progress, time_limit=args.time_limit)
    finally:
        progress.close()
    print(proof.text())
    print(f"wrote {Path(args.out) / 'proof.json'} and {Path(args.out) / 'proof.md'}")
    return 0


def act(args) -> int:
    from .enactment import make_recording

    odb = _odb(args)
    _claim(args, replaced=[args.out], inputs=[args.world])
    recording = make_recording(Path(args.world), args.action, list(args.args), Path(args.out), odb,
                               _templates(args, odb), overwrite=args.overwrite)
    print(f"wrote recording {recording.folder} ({recording.telemetry.duration:.1f} s of telemetry)")
    return 0
