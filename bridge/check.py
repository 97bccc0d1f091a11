"""`bridge check`: load everything `bridge infer` would, so a problem shows before a replay, not after one.

- the object database: every concrete type's SIEs made with their parameters (`ObjectDatabase.check_sies`, done
  when it is read), each type built alone in Drake (mass properties, meshes, robot models: `bridge.sim.checks`);
- the PDDL side: ``domain.yaml`` (name, requirements) and the action templates, the domain built from them;
- each recording folder or world-state file named: read as `infer` reads it (world state against the database,
  telemetry, observed poses, the ``--scene``/``--params`` files applied with every target checked against its
  world), then its scene built and a replay started in Drake (the telemetry checked against the robot's joints,
  the scene values written), without simulating.

Every function returns what it checked, as text; a problem is the `BridgeError` `infer` would raise.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterator, Sequence

from .errors import ParameterError, RecordingError, WorldStateError
from .files import read_yaml
from .odb import ObjectDatabase
from .params import apply_model, kind_named, load_param_file, replay_model
from .planning.domain import build_domain
from .planning.templates import check_requirements, load_action_templates, load_domain_settings
from .recording.recording import load_recording
from .rollout.rollout import Rollout, check_rollout
from .sim.checks import check_type
from .world import load_world_state, world_from_dict

TELEMETRY_TARGETS = ("robot", "joints")  # kinds that change the telemetry: nothing to change in a world alone


def check_database(odb: ObjectDatabase) -> str:
    """The database as read, its SIEs made, and each concrete type built alone in Drake."""
    sies = odb.check_sies()
    concrete = odb.concrete_types()
    skipped = [name for name in concrete if not check_type(odb, name)]
    lines = [f"object database {odb.root}: {len(odb.types)} types ({len(concrete)} concrete), "
             f"{len(odb.predicates)} predicates, PDDL types: {', '.join(sorted(odb.pddl_types))}",
             f"  {sies} SIEs made with their parameters; {len(concrete) - len(skipped)} types built in Drake "
             f"(mass properties, meshes, robot models)"]
    if skipped:
        lines.append(f"  not checked (dataset not found): {', '.join(skipped)}")
    return "\n".join(lines)


def check_domain(root: str | Path, odb: ObjectDatabase) -> str:
    """``domain.yaml`` and the action templates under `root`, and the PDDL domain they make (its requirements
    checked to cover what the actions use)."""
    root = Path(root)
    settings = load_domain_settings(root)
    templates = load_action_templates(root / "templates", odb)
    requirements = ", ".join(check_requirements(settings, templates))
    domain = build_domain(odb, templates, settings=settings)
    return (f"domain {domain.name} ({settings.source}): requirements {requirements}\n"
            f"action templates {root / 'templates'}: {', '.join(sorted(templates))}")


def check_input(path: str | Path, odb: ObjectDatabase, *, scene: str | Path | None = None,
                params: str | Path | None = None) -> str:
    """A recording folder or a world-state file, loaded as `bridge infer` loads it, the scene and parameter files
    applied, and the replay started in Drake without simulating."""
    path = Path(path)
    if not path.exists():
        raise RecordingError("no such recording folder or world-state file", source=str(path))
    if path.is_dir():
        recording = load_recording(path)
        world = load_world_state(recording.world_path, odb)
        rollout = Rollout(world, recording.telemetry, name=recording.name)
        if recording.observations is not None:  # what fit and diagnose compare, checked as they check it
            unknown = [name for name in recording.observations.objects if name not in world.objects]
            if unknown:
                raise RecordingError(f"observed object {unknown[0]!r} is not in world.yaml; objects: "
                                     f"{', '.join(world.objects)}", source=recording.observations.source)
        tel = recording.telemetry
        what = (f"recording {path}: world {world.name!r} ({_contents(world)}), telemetry {len(tel)} samples over "
                f"{tel.duration:.1f} s ({len(tel.joint_names)} joints)")
        if recording.observations is not None:
            what += f", observed: {', '.join(recording.observations.objects)}"
    else:
        data = read_yaml(path, "world-state file", WorldStateError)
        if isinstance(data, dict) and "params" in data and "objects" not in data:
            raise ParameterError("this is a parameter (or scene) file; check it against what it applies to: "
                                 "bridge check RECORDING --scene FILE (or --params FILE)", source=str(path))
        world = world_from_dict(data, odb, str(path))
        rollout = Rollout(world, None, name=world.name)
        what = f"world state {path}: {world.name!r} ({_contents(world)}, {len(world.facts)} facts)"
    applied = []
    for option, file in (("--scene", scene), ("--params", params)):
        if file:
            rollout = _apply_file(rollout, odb, file)
            applied.append(f"{option} {file}")
    check_rollout(rollout, odb)
    return what + (f"; {', '.join(applied)} applied" if applied else "") + "; scene built in Drake"


def check_inputs(paths: Sequence[str | Path], odb: ObjectDatabase, *, scene: str | Path | None = None,
                 params: str | Path | None = None) -> Iterator[str]:
    """`check_input` for each path, one line each as it is checked. A scene or parameter file without a path is
    refused at once: it needs something to check its targets against."""
    if not paths and (scene or params):
        option, file = ("--scene", scene) if scene else ("--params", params)
        raise ParameterError(f"{option} needs a recording or world state to check its targets against: bridge check "
                             f"RECORDING {option} {file}", source=str(file))
    return (check_input(path, odb, scene=scene, params=params) for path in paths)


def _apply_file(rollout: Rollout, odb: ObjectDatabase, path: str | Path) -> Rollout:
    """A scene or parameter file applied as `bridge infer --scene/--params` applies it. A world state alone has
    no telemetry: latency and joint offsets have nothing to change, only their targets are checked."""
    model = replay_model(load_param_file(path))
    if rollout.telemetry is None:
        timed = [s for s in model if kind_named(s.kind).targets in TELEMETRY_TARGETS]
        for s in timed:
            kind = kind_named(s.kind)
            if not kind.select(s.target, rollout.world, odb):
                raise ParameterError(f"{s.name}: {s.target!r} names nothing in world {rollout.world.name!r}; "
                                     f"{kind.valid_targets([rollout.world], odb)}", source=str(path))
        model = tuple(s for s in model if s not in timed)
    return apply_model(model, rollout, odb, source=str(path))


def _contents(world) -> str:
    robot = f", robot {world.robot.name} ({world.robot.type})" if world.robot is not None else ", no robot"
    return f"{len(world.objects)} objects{robot}"
