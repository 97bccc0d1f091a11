"""The `bridge` command: parses arguments and calls one command function (`bridge.commands`); nothing else
lives here."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Callable, Sequence

from . import commands

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_TEMPLATES = REPO_ROOT / "pddl"


COMMANDS: dict[str, tuple[Callable, str]] = {
    "infer": (commands.infer, "replay a recording in Drake and infer the world state after it"),
    "demo": (commands.demo, "run the paper's four trials and print what changed in each"),
    "view": (commands.view, "write a self-contained HTML replay of a recording (observed poses as ghosts)"),
    "act": (commands.act, "make a recording from an action template's body"),
    "fit": (commands.fit, "fit simulation parameters (friction, mass, ...) to recordings with observed poses"),
    "diagnose": (commands.diagnose, "locate where simulation and recordings differ, name the missing physics, model it"),
    "prove": (commands.prove, "conceal each effect in generated recordings and diagnose them blind (confusion matrix)"),
    "check": (commands.check, "validate the object database, domain.yaml and the action templates, and load "
              "recordings or world states as infer would (without simulating)"),
    "export": (commands.export, "write the PDDL domain and problem of a world state"),
    "diff": (commands.diff, "compare two world states (or a world state and a PDDL problem)"),
    "apply": (commands.apply, "apply a ground action template to a world state"),
}


# --- option values: a value outside its range is argparse's one line naming the option ---------------------------
def _number(text: str, kind: type, low: float, strict: bool, what: str) -> float | int:
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
    if not math.isfinite(value) or value < low or (strict and value == low):
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
    return value


def positive_float(text: str) -> float:
    return _number(text, float, 0.0, True, "a finite number > 0")


def finite_nonneg_float(text: str) -> float:
    return _number(text, float, 0.0, False, "a finite number >= 0")


def nonneg_int(text: str) -> int:
    return _number(text, int, 0, False, "a whole number >= 0")


def positive_int(text: str) -> int:
    return _number(text, int, 1, False, "a whole number >= 1")


def popsize_int(text: str) -> int:
    return _number(text, int, 2, False, "a whole number >= 2 (an evolution needs two candidates to compare)")


def seconds(text: str) -> float:
    return _number(text, float, 0.0, True, "a finite number of seconds > 0")


def _time_step(text: str) -> float | str:
    return "auto" if text == "auto" else positive_float(text)


def _time_limit_arg(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--time-limit", type=seconds, default=None, metavar="SECONDS",
                   help=f"after this many seconds {what}, marked partial (default: no limit)")


def _shape_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--shape", default=None, metavar="NAME", help="the shape pushed in MIT .h5 files whose name does "
                   "not follow the dataset's pattern and that have no 'shape' attribute, e.g. rect1")


def _sample_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--samples", type=nonneg_int, default=0, metavar="N", help="also replay N times with parameters drawn "
                   "from the uncertainty of --scene/--params (their std) or the object database's ranges")
    p.add_argument("--seed", type=nonneg_int, default=0, help="seeds the drawn parameters (default %(default)s)")
    p.add_argument("--executor", choices=("process", "dask", "serial"), default="process",
                   help="where the samples run (default: %(default)s)")
    p.add_argument("--workers", type=positive_int, default=None, help="worker processes (default: one per CPU)")


def _probability_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--min-probability", type=float, default=0.9, metavar="P", help="facts at least this likely "
                   "go into the PDDL problem; the uncertain ones are listed beside it (default %(default)s)")


def _model_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scene", default=None, metavar="FILE", help="diagnosed scene file (scene.yaml from bridge diagnose)")
    p.add_argument("--params", default=None, metavar="FILE", help="fitted parameter file (params.yaml from bridge "
                   "fit); with --scene, its values go on top of the scene's")


def _sleep_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--no-sleep", dest="sleep", action="store_false", help="simulate every object at every step, "
                   "also those at rest out of the robot's reach and while nothing moves or is commanded to move (the full "
                   "simulation: slower, the same result to well under a millimetre; docs/rollout.md, sleeping objects "
                   "and still spans)")


class _Parser(argparse.ArgumentParser):
    """A refused option is one line naming it, like every other bad input (argparse prints the usage first)."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="bridge", description="Keep a robot's symbolic world state true while a person teleoperates it: "
        "replay its telemetry in Drake, infer the facts, write PDDL, fit and diagnose the physics.")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--odb", default=None, help="object database folder (default: the bundled odb/)")
    common.add_argument("--templates", default=str(DEFAULT_TEMPLATES), help="folder with domain.yaml and templates/ (default: %(default)s)")
    common.add_argument("--dataset", action="append", metavar="NAME=PATH",
                        help="root of a dataset named in dataset:// mesh paths, e.g. mit-push=../shared/datasets/mit-push")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=_Parser)

    def add(name: str) -> argparse.ArgumentParser:
        func, text = COMMANDS[name]
        p = sub.add_parser(name, parents=[common], help=text, description=text)
        p.set_defaults(func=func)
        return p

    p = add("check")
    p.add_argument("paths", nargs="*", metavar="PATH", help="recording folders or world-state files to load as infer "
                   "would: world state, telemetry, observed poses, --scene/--params targets, the scene built in Drake")
    _model_args(p)
    p = add("export")
    p.add_argument("world", help="world-state YAML")
    p.add_argument("--out", default=".", help="folder for domain.pddl and problem.pddl (default: current folder)")
    p.add_argument("--goal", default=None, help="PDDL goal, e.g. '(and (on big_box tray))' (default: the world's goal)")
    _probability_arg(p)
    p = add("diff")
    p.add_argument("a", help="world state before")
    p.add_argument("b", help="world state after, or a PDDL problem (.pddl)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--translation", type=finite_nonneg_float, default=0.01, help="moved when translated more than this (m, default %(default)s)")
    p.add_argument("--rotation", type=finite_nonneg_float, default=5.0, help="moved when turned more than this (deg, default %(default)s)")
    p = add("apply")
    p.add_argument("world", help="world-state YAML")
    p.add_argument("action", help="action template name, e.g. pick")
    p.add_argument("args", nargs="*", help="the action's arguments (object names)")
    p.add_argument("--out", default=None, help="write the successor world state here")
    p = add("infer")
    p.add_argument("recording", help="recording folder (world.yaml, telemetry, optional observed.csv) or MIT .h5 file")
    p.add_argument("--world-out", default=None, help="inferred world state (default: out/NAME/world_after.yaml "
                   "under the current folder, NAME the recording folder's name or the .h5 file's stem)")
    p.add_argument("--problem-out", default=None, help="PDDL problem of it (default: problem_after.pddl beside "
                   "--world-out)")
    p.add_argument("--events", action="store_true", help="print predicate changes as JSON lines while replaying")
    p.add_argument("--event-period", type=positive_float, default=0.1, help="simulated seconds between on-line inferences (default %(default)s)")
    _model_args(p)
    _sleep_arg(p)
    _sample_args(p)
    _time_limit_arg(p, "wait for no further sample (with --samples): the probabilities are over the samples done")
    _shape_arg(p)
    _probability_arg(p)
    p = add("demo")
    p.add_argument("--recordings", default=str(REPO_ROOT / "demo" / "recordings"), help="folder of recordings (default: the bundled trials)")
    p.add_argument("--out", default="out/demo", help="where to write inferred states (default: %(default)s)")
    _model_args(p)
    _sleep_arg(p)
    p = add("view")
    p.add_argument("recording", help="recording folder or MIT .h5 file")
    p.add_argument("--out", default=None, help="HTML file (default: out/NAME/replay.html under the current folder, "
                   "NAME the recording folder's name or the .h5 file's stem)")
    _model_args(p)
    _sleep_arg(p)
    _sample_args(p)
    _shape_arg(p)
    p = add("act")
    p.add_argument("world", help="world state before the action")
    p.add_argument("action", help="action template, e.g. push_over")
    p.add_argument("args", nargs="*", help="the action's arguments")
    p.add_argument("--out", required=True, help="recording folder to write (written whole: an interrupted run "
                   "leaves the old folder or none)")
    p.add_argument("--overwrite", action="store_true", help="replace the recording in a non-empty --out folder "
                   "(its other files are kept)")
    p = add("fit")
    p.add_argument("recordings", nargs="+", metavar="RECORDING",
                   help="recording folders (with observed.csv), MIT .h5 files, or folders of .h5 files")
    p.add_argument("--out", required=True, metavar="DIR", help="report folder (params.yaml, fit.json, table1.md, "
                   "figures) and checkpoint.json")
    p.add_argument("--params", default=None, metavar="FILE", help="parameter file saying what to fit (default: "
                   "the friction of the moved objects and of what they touch)")
    p.add_argument("--scene", default=None, metavar="FILE", help="fit on top of a diagnosed scene file (scene.yaml "
                   "from bridge diagnose: its extra geometry, corrections and values stay fixed)")
    p.add_argument("--optimizer", choices=("cmaes", "es", "lm"), default="cmaes", help="cmaes, the paper's es, or "
                   "lm (Levenberg-Marquardt on the same error; default: %(default)s)")
    p.add_argument("--generations", type=positive_int, default=30, help="at most this many (default %(default)s; stops "
                   "earlier when the best error stops improving)")
    p.add_argument("--popsize", type=popsize_int, default=None, help="candidates per generation (default: cmaes 4 + 3 ln D, "
                   "es 10 D as in the paper)")
    p.add_argument("--seed", type=nonneg_int, default=0, help="seeds the optimiser and the hold-out split (default %(default)s)")
    p.add_argument("--executor", choices=("process", "dask", "serial"), default="process", help="default: %(default)s")
    p.add_argument("--workers", type=positive_int, default=None, help="worker processes (default: one per CPU)")
    p.add_argument("--scheduler", default=None, metavar="ADDR", help="a dask scheduler's address (with --executor dask)")
    p.add_argument("--hold-out", type=nonneg_int, default=None, metavar="N", help="trials kept out of the fit to test it "
                   "(default: 25%% when there are 4 or more)")
    p.add_argument("--resume", action="store_true", help="continue from DIR/checkpoint.json")
    p.add_argument("--max-duration", type=positive_float, default=None, metavar="S", help="use only the first S seconds of "
                   "each MIT push")
    _shape_arg(p)
    _time_limit_arg(p, "start no further generation: the result is the best candidate so far")
    p = add("diagnose")
    p.add_argument("recordings", nargs="+", metavar="RECORDING",
                   help="recording folders (with observed.csv), MIT .h5 files, or folders of .h5 files")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for diagnosis.json, report.md, scene.yaml, plots")
    p.add_argument("--hold-out", type=nonneg_int, default=None, metavar="N", help="recordings kept out of the fit to check "
                   "it (default: a quarter when there are 4 or more)")
    p.add_argument("--effects", default=None, metavar="A,B", help="only these effects of the catalog (default: all)")
    p.add_argument("--workers", type=positive_int, default=None, help="worker processes (default: up to 2)")
    p.add_argument("--max-duration", type=positive_float, default=None, metavar="S", help="use only the first S seconds of "
                   "each MIT push")
    _shape_arg(p)
    _time_limit_arg(p, "try no further candidate: the verdict is the best of what was tried")
    p.add_argument("--time-step", type=_time_step, default="auto", metavar="SECONDS|auto",
                   help="time step of every replay; auto: 3 ms when that changes the nominal replays by at most 1 %% "
                   "of their misfit, else the recordings' own 2 ms (default: %(default)s)")
    p.add_argument("--own-speed", action="store_true", help="replay every recording at its own speed (default: slow "
                   "recordings are replayed up to 25 mm/s where that changes their nominal replay by at most 1 %% of "
                   "their misfit: quasi-static pushing does not depend on speed)")
    p.add_argument("--fit-contact", action=argparse.BooleanOptionalAction, default=True,
                   help="fit the object's contact stiffness and damping with the friction coefficients as the ordinary "
                   "model, so that no effect is credited with a contact the model has wrong; --no-fit-contact keeps "
                   "the object database's (default: fitted; docs/diagnosis.md section 3)")
    p = add("prove")
    p.add_argument("--size", choices=("small", "full"), default="small", help="small: one case per effect (CI); "
                   "full: three magnitudes, two seeds (default: %(default)s)")
    p.add_argument("--world", choices=("matched", "mismatched", "both"), default="both",
                   help="matched: recordings made by the diagnosis' own model; mismatched: worlds that differ from it "
                   "beneath the effect (contact, time step, servo, sensors, frictions; full size needs the MIT "
                   "dataset's meshes); both, reported side by side (default: %(default)s)")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for the generated recordings and proof.json")
    p.add_argument("--workers", type=positive_int, default=None, help="worker processes (default: up to 2)")
    _time_limit_arg(p, "start no further case: proof.json covers the cases done")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return commands.run(args.func, args)


if __name__ == "__main__":
    sys.exit(main())
