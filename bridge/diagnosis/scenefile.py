"""Scene files: the diagnosed effect and the fitted ordinary parameters, as replay, `bridge infer` and
`bridge fit` use them from then on.

    # bridge scene file (written by bridge diagnose)
    format: 1
    effects:
      - {effect: friction, target: block, params: {mu: 0.21}}          # ordinary parameter, fitted first
      - {effect: com_offset, target: block, params: {dx: -0.010, dy: 0.003}}
    diagnosis: {verdict: com_offset, ...}                             # provenance; ignored when read

`load_scene_file(path)` reads and checks the file's shape (effect names, parameter names, numbers);
`SceneFile.resolve(world, odb)` checks targets against a world and returns the `Setup`: SceneParams, a
telemetry transform, scene extras, context hooks and world pose overrides. `scene_setting` applies it to one
recording: the world and telemetry to replay, with the scene values, extras and hooks; `trials_under` applies it
to fit trials.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

import yaml

from ..errors import DiagnosisError
from ..fit.trials import Trial
from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..files import write_atomic
from ..world import WorldState
from .effects import EFFECTS, Applied, get_effect
from .simulation import Setup, resolve

FORMAT = 1
KEYS = ("format", "effects", "diagnosis")
EFFECT_KEYS = ("effect", "target", "params")


@dataclass(frozen=True)
class SceneFile:
    effects: tuple[Applied, ...]
    source: str = "<memory>"
    diagnosis: Mapping[str, Any] | None = None

    def check(self, world: WorldState, odb: ObjectDatabase) -> None:
        """Targets exist in `world`; parameters are the effect's and numbers."""
        for i, a in enumerate(self.effects):
            effect = get_effect(a.effect)
            fld = f"effects[{i}]"
            valid = _valid_targets(effect, world, odb)
            if a.target not in valid:
                raise DiagnosisError(f"effect {a.effect!r} cannot target {a.target!r} in world {world.name!r}; "
                                     f"valid targets: {', '.join(valid) or 'none'}", source=self.source,
                                     field=f"{fld}.target")
            effect.check_values(world, odb, a.target, a.values(), source=f"{self.source}: {fld}.params")

    def resolve(self, world: WorldState, odb: ObjectDatabase) -> Setup:
        self.check(world, odb)
        return resolve(self.effects, world, odb)

    def to_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {"format": FORMAT, "effects": [
            {"effect": a.effect, "target": a.target, "params": {k: float(f"{v:.8g}") for k, v in a.params}}
            for a in self.effects]}
        if self.diagnosis:
            data["diagnosis"] = dict(self.diagnosis)
        return data


def _valid_targets(effect, world: WorldState, odb: ObjectDatabase) -> list[str]:
    names = [n for n in world.objects]
    targets = list(effect.targets(world, odb, names))
    if effect.name == "none":
        targets.append("world")
    return list(dict.fromkeys(targets))


def load_scene_file(path: str | Path) -> SceneFile:
    from ..files import read_yaml

    path = Path(path)
    return parse_scene(read_yaml(path, "scene file", DiagnosisError), str(path))


def parse_scene(data: Any, source: str = "<memory>") -> SceneFile:
    if not isinstance(data, dict) or "effects" not in data:
        raise DiagnosisError("a scene file is a mapping with an 'effects' list", source=source)
    unknown = sorted(set(data) - set(KEYS), key=str)
    if unknown:
        raise DiagnosisError(f"unknown key {unknown[0]!r}; valid keys: {', '.join(KEYS)}", source=source)
    if data.get("format", FORMAT) != FORMAT:
        raise DiagnosisError(f"format {data.get('format')!r} is not supported (this version reads {FORMAT})",
                             source=source, field="format")
    raw = data["effects"]
    if not isinstance(raw, list):
        raise DiagnosisError("must be a list of {effect, target, params}", source=source, field="effects")
    effects = []
    for i, body in enumerate(raw):
        fld = f"effects[{i}]"
        if not isinstance(body, dict):
            raise DiagnosisError("must be a mapping {effect, target, params}", source=source, field=fld)
        bad = sorted(set(body) - set(EFFECT_KEYS), key=str)
        if bad:
            raise DiagnosisError(f"unknown key {bad[0]!r}; valid keys: {', '.join(EFFECT_KEYS)}", source=source,
                                 field=fld)
        name = body.get("effect")
        if name not in EFFECTS:
            raise DiagnosisError(f"unknown effect {name!r}; effects: {', '.join(EFFECTS)}", source=source,
                                 field=f"{fld}.effect")
        target = body.get("target", "world" if name == "none" else None)
        if not isinstance(target, str) or not target:
            raise DiagnosisError("missing target (an object, surface, robot or robot:joint name)", source=source,
                                 field=f"{fld}.target")
        params = body.get("params") or {}
        if not isinstance(params, dict):
            raise DiagnosisError("must map parameter names to numbers", source=source, field=f"{fld}.params")
        values = {}
        for k, v in params.items():
            if isinstance(v, str):
                try:
                    v = float(v)
                except ValueError:
                    pass
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise DiagnosisError(f"must be a finite number, got {v!r}", source=source, field=f"{fld}.params.{k}")
            values[str(k)] = float(v)
        effects.append(Applied.of(name, target, values))
    diagnosis = data.get("diagnosis")
    return SceneFile(tuple(a for a in effects if a.effect != "none"), source,
                     diagnosis if isinstance(diagnosis, dict) else None)


def save_scene_file(path: str | Path, effects: Sequence[Applied], diagnosis: Mapping[str, Any] | None = None) -> Path:
    path = Path(path)
    scene = SceneFile(tuple(effects), str(path), diagnosis)
    header = "# bridge scene file (bridge diagnose): the fitted ordinary parameters and the diagnosed effect.\n" \
             "# Use it with replay (bridge.diagnosis.scenefile.scene_setting) and --scene where supported.\n"
    write_atomic(path, header + yaml.safe_dump(scene.to_dict(), sort_keys=False, default_flow_style=None, width=120))
    return path


@dataclass(frozen=True, eq=False)
class SceneSetting:
    """What one replay of a recording runs with under a scene file: `build_scene(world, odb, extras=extras)`,
    then `simulate_tracks(scene, telemetry, world=world, params=params, hooks=hooks)` (or `replay` when there
    are no hooks)."""

    world: WorldState
    params: Any  # SceneParams
    telemetry: Telemetry
    extras: tuple
    hooks: tuple


def scene_setting(scene: SceneFile, world: WorldState, telemetry: Telemetry, odb: ObjectDatabase) -> SceneSetting:
    """The scene file applied to one recording (its world state before and its telemetry)."""
    setup = scene.resolve(world, odb)
    return SceneSetting(setup.world(world), setup.params, setup.telemetry.apply(telemetry), setup.extras, setup.hooks)


def replay_setting(scene: SceneFile, world: WorldState, telemetry: Telemetry, odb: ObjectDatabase) -> SceneSetting:
    """`scene_setting` for the ordinary replay (`bridge infer`, `view`, `demo`, `fit`), which runs no context
    hooks: a scene file that needs them is refused."""
    setting = scene_setting(scene, world, telemetry, odb)
    if setting.hooks:
        raise DiagnosisError("this scene file needs context hooks, which only the diagnosis' replay runs",
                             source=scene.source)
    return setting


def trials_under(scene: SceneFile, trials: Sequence[Trial], odb: ObjectDatabase) -> list[Trial]:
    """The trials as the scene file has them (for `bridge fit --scene`): its world corrections, telemetry,
    extra geometry and values, on top of which the fit's own parameters go."""
    out = []
    for trial in trials:
        setting = replay_setting(scene, trial.world, trial.telemetry, odb)
        out.append(replace(trial, world=setting.world, telemetry=setting.telemetry, extras=tuple(setting.extras),
                           base_params=setting.params))
    return out
