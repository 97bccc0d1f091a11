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
    odb = _odb(args)
    templates = _templates(args, odb)
    concrete = odb.concrete_types()
    print(f"object database {odb.root}: {len(odb.types)} types ({len(concrete)} concrete), "
          f"{len(odb.predicates)} predicates, PDDL types: {', '.join(sorted(odb.pddl_types))}")
    for name in concrete:  # mass properties of every usable type, so a broken mesh shows now
        t = odb.types[name]
        if t.geometry is not None and t.geometry.unresolved is None and not t.fixed and not t.is_robot:
            odb.mass_properties(name)
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


COMMANDS: dict[str, tuple[Callable, str]] = {
    "check": (cmd_check, "validate the object database and the action templates"),
    "export": (cmd_export, "write the PDDL domain and problem of a world state"),
    "diff": (cmd_diff, "compare two world states (or a world state and a PDDL problem)"),
    "apply": (cmd_apply, "apply a ground action template to a world state"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bridge", description=__doc__.splitlines()[0] if __doc__ else None)
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
