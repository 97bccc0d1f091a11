"""Parameter files: which simulation parameters a fit may change (bounds, start, scale) or holds fixed (value).

    params:
      - {kind: friction, target: big_box, bounds: [0.1, 1.0], start: 0.5}   # target: an object, or type:<type>
      - {kind: friction, target: pusher/pusher_rod, bounds: [0.05, 1.0]}    # a robot link (contact kinds only)
      - {kind: hydroelastic_modulus, target: big_box, bounds: [1e5, 1e8], start: 1e6, scale: log}
      - {kind: mass, target: big_box, bounds: [0.5, 2.0]}                   # start: middle of the bounds
      - {kind: com_x, target: big_box, value: 0.01}                         # fixed: applied, not fitted

A *kind* says how a value changes one evaluation of a trial: the scene parameters written into a Drake context
(`SceneParams`, no rebuild) and/or the telemetry replayed. Kinds live in the explicit registry
`PARAMETER_KINDS` (`kinds.py`, re-exported here); a new kind is one class registered with `@register_kind`.
A fitted parameter file (what `bridge fit` writes as params.yaml) holds only fixed values; `bridge infer`,
`view` and `demo` read it with `--params`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import yaml

from ..errors import FitError
from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..sim.scene import SceneParams
from ..files import write_atomic
from ..world import WorldState
from .kinds import PARAMETER_KINDS, ParameterKind, Setting, register_kind

SCALES = ("linear", "log")
ENTRY_KEYS = ("kind", "target", "bounds", "start", "value", "scale")
FILE_KEYS = ("params", "fit")  # `fit`: what bridge fit records about the run; ignored when reading


# --- a parameter file ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ParamSpec:
    """One entry: free when it has `bounds` and no `value`, fixed otherwise."""

    kind: ParameterKind
    target: str
    bounds: tuple[float, float] | None = None
    start: float | None = None
    value: float | None = None
    scale: str = "linear"

    @property
    def name(self) -> str:
        return f"{self.kind.name}[{self.target}]"

    @property
    def free(self) -> bool:
        return self.value is None

    @property
    def start_value(self) -> float:
        """The start: `start`, else the middle of the bounds (geometric middle on a log scale)."""
        if self.start is not None:
            return self.start
        lo, hi = self.bounds
        return math.sqrt(lo * hi) if self.scale == "log" else 0.5 * (lo + hi)

    def to_unit(self, value: float) -> float:
        lo, hi = self.bounds
        if self.scale == "log":
            return (math.log(value) - math.log(lo)) / (math.log(hi) - math.log(lo))
        return (value - lo) / (hi - lo)

    def from_unit(self, u: float) -> float:
        lo, hi = self.bounds
        u = min(1.0, max(0.0, float(u)))
        if self.scale == "log":
            return float(math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo))))
        return float(lo + u * (hi - lo))


@dataclass(frozen=True)
class ParameterSpec:
    """The entries of a parameter file, in file order; fixed entries are applied before free ones."""

    entries: tuple[ParamSpec, ...]
    source: str = "<memory>"

    @property
    def free(self) -> tuple[ParamSpec, ...]:
        return tuple(p for p in self.entries if p.free)

    @property
    def fixed(self) -> tuple[ParamSpec, ...]:
        return tuple(p for p in self.entries if not p.free)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the free parameters, the order of every parameter vector."""
        return tuple(p.name for p in self.free)

    def start_values(self) -> np.ndarray:
        return np.array([p.start_value for p in self.free])

    def to_unit(self, values: Sequence[float]) -> np.ndarray:
        return np.array([p.to_unit(v) for p, v in zip(self.free, values)])

    def from_unit(self, u: Sequence[float]) -> np.ndarray:
        return np.array([p.from_unit(v) for p, v in zip(self.free, u)])

    def as_dict(self, values: Sequence[float]) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.names, values)}

    def fixed_at(self, values: Sequence[float] | Mapping[str, float]) -> "ParameterSpec":
        """The same parameters with the free ones fixed at `values` (a fitted parameter file)."""
        if isinstance(values, Mapping):
            values = [values[n] for n in self.names]
        it = iter(float(v) for v in values)
        return replace(self, entries=tuple(p if not p.free else replace(p, value=next(it)) for p in self.entries))

    def to_dict(self) -> dict[str, Any]:
        return {"params": [_entry_dict(p) for p in self.entries]}


def apply_params(spec: ParameterSpec, values: Sequence[float] | None, world: WorldState, telemetry: Telemetry,
                 odb: ObjectDatabase, base: SceneParams | None = None) -> tuple[SceneParams, Telemetry]:
    """Scene parameters and telemetry for one trial: `base` (a diagnosed scene file's values), then fixed
    entries, then free ones at `values` (parameter units, in `spec.names` order; None: their start values)."""
    free = spec.free
    values = spec.start_values() if values is None else np.asarray(values, dtype=float)
    if len(values) != len(free):
        raise FitError(f"{len(values)} values for the {len(free)} free parameters {', '.join(spec.names)}")
    setting = Setting(world, base or SceneParams(), telemetry, odb)
    free_values = iter(values)
    for p in spec.entries:
        value = p.value if not p.free else float(next(free_values))
        names = p.kind.select(p.target, world, odb)
        if names:
            setting = p.kind.apply(value, names, setting)
    return setting.params, setting.telemetry


def scene_setting(spec: ParameterSpec, world: WorldState, telemetry: Telemetry, odb: ObjectDatabase,
                  base: SceneParams | None = None) -> tuple[SceneParams, Telemetry]:
    """For `bridge infer`/`view`/`demo --params`: the file's values (a free entry's start; no start is an error),
    on top of `base` (a diagnosed scene file's values)."""
    missing = [p.name for p in spec.free if p.start is None]
    if missing:
        raise FitError(f"parameter {missing[0]} has bounds but no value; pass a fitted parameter file (the "
                       "params.yaml bridge fit writes) or give each entry a value", source=spec.source)
    check_targets(spec, [world], odb)
    return apply_params(spec, None, world, telemetry, odb, base=base)


def check_targets(spec: ParameterSpec, worlds: Sequence[WorldState], odb: ObjectDatabase) -> None:
    """Every target selects something in at least one world; an error lists what could be named."""
    for index, p in enumerate(spec.entries):
        if any(p.kind.select(p.target, w, odb) for w in worlds):
            continue
        raise FitError(f"unknown target {p.target!r} for {p.kind.name}; {_valid_targets(p.kind, worlds, odb)}",
                       source=spec.source, field=f"params[{index}].target")


def _valid_targets(kind: ParameterKind, worlds: Sequence[WorldState], odb: ObjectDatabase) -> str:
    robots = sorted({w.robot.name for w in worlds if w.robot is not None})
    if kind.targets == "robot":
        return f"{kind.name} targets the robot: {', '.join(robots) or 'none in the trials'}"
    if kind.targets == "joints":
        joints = sorted({j for w in worlds if w.robot is not None for j in odb.get(w.robot.type).robot.joints})
        return f"{kind.name} targets a joint: {', '.join(joints) or 'none in the trials'}"
    objects = sorted({n for w in worlds for n, o in w.objects.items()
                      if kind.targets != "free objects" or not odb.get(o.type).fixed})
    types = sorted({o.type for w in worlds for o in w.objects.values()})
    text = f"objects in the trials: {', '.join(objects)}; or type:<type> with a type among {', '.join(types)}"
    if kind.targets == "contacts" and robots:
        text += f"; or a robot link <robot>/<link> of {', '.join(robots)}"
    return text


# --- reading and writing -------------------------------------------------------------------------------------
def load_param_file(path: str | Path) -> ParameterSpec:
    """Read and check a parameter file; every problem names the file and the entry."""
    from ..files import read_yaml

    path = Path(path)
    return parse_params(read_yaml(path, "parameter file", FitError), str(path))


def parse_params(data: Any, source: str = "<memory>") -> ParameterSpec:
    if not isinstance(data, dict) or "params" not in data:
        raise FitError("a parameter file is a mapping with a 'params' list", source=source)
    unknown = sorted(set(data) - set(FILE_KEYS), key=str)
    if unknown:
        raise FitError(f"unknown key {unknown[0]!r}; valid keys: {', '.join(FILE_KEYS)}", source=source)
    raw = data["params"]
    if not isinstance(raw, list) or not raw:
        raise FitError("must be a non-empty list of {kind, target, bounds | value, ...} entries", source=source,
                       field="params")
    entries = tuple(_parse_entry(body, source, f"params[{i}]") for i, body in enumerate(raw))
    seen: dict[str, int] = {}
    for i, p in enumerate(entries):
        if p.name in seen:
            raise FitError(f"{p.name} is given twice (also params[{seen[p.name]}])", source=source, field=f"params[{i}]")
        seen[p.name] = i
    return ParameterSpec(entries, source)


def _parse_entry(body: Any, source: str, fld: str) -> ParamSpec:
    if not isinstance(body, dict):
        raise FitError("must be a mapping {kind, target, bounds, start} or {kind, target, value}", source=source,
                       field=fld)
    unknown = sorted(set(body) - set(ENTRY_KEYS), key=str)
    if unknown:
        raise FitError(f"unknown key {unknown[0]!r}; valid keys: {', '.join(ENTRY_KEYS)}", source=source, field=fld)
    for key in ("kind", "target"):
        if key not in body:
            raise FitError(f"missing field {key!r}", source=source, field=fld)
    kind_name = body["kind"]
    if kind_name not in PARAMETER_KINDS:
        raise FitError(f"unknown kind {kind_name!r}; kinds: {', '.join(sorted(PARAMETER_KINDS))}", source=source,
                       field=f"{fld}.kind")
    kind = PARAMETER_KINDS[kind_name]
    target = body["target"]
    if not isinstance(target, str) or not target.strip():
        raise FitError(f"must be an object name, type:<type>, a robot link or a joint, got {target!r}",
                       source=source, field=f"{fld}.target")
    scale = body.get("scale", "linear")
    if scale not in SCALES:
        raise FitError(f"scale {scale!r} is not one of {', '.join(SCALES)}", source=source, field=f"{fld}.scale")
    if "value" in body:
        if "bounds" in body or "start" in body:
            raise FitError("give 'value' (fixed) or 'bounds' and 'start' (fitted), not both", source=source, field=fld)
        value = _number(body["value"], source, f"{fld}.value")
        _check_kind(kind, value, source, f"{fld}.value")
        return ParamSpec(kind, target, value=value, scale=scale)
    if "bounds" not in body:
        raise FitError("missing field 'bounds' (a fitted parameter) or 'value' (a fixed one)", source=source, field=fld)
    bounds = body["bounds"]
    if not isinstance(bounds, (list, tuple)) or len(bounds) != 2:
        raise FitError(f"must be two numbers [low, high], got {bounds!r}", source=source, field=f"{fld}.bounds")
    lo, hi = (_number(b, source, f"{fld}.bounds[{k}]") for k, b in enumerate(bounds))
    if not lo < hi:
        raise FitError(f"bounds must increase (low < high), got [{lo:g}, {hi:g}]", source=source, field=f"{fld}.bounds")
    for k, b in enumerate((lo, hi)):
        _check_kind(kind, b, source, f"{fld}.bounds[{k}]")
    if scale == "log" and lo <= 0:
        raise FitError(f"a log scale needs bounds > 0, got [{lo:g}, {hi:g}]", source=source, field=f"{fld}.bounds")
    start = None
    if "start" in body and body["start"] is not None:
        start = _number(body["start"], source, f"{fld}.start")
        if not lo <= start <= hi:
            raise FitError(f"start {start:g} is outside the bounds [{lo:g}, {hi:g}]", source=source,
                           field=f"{fld}.start")
    return ParamSpec(kind, target, bounds=(lo, hi), start=start, scale=scale)


def _number(value: Any, source: str, fld: str) -> float:
    if isinstance(value, str):  # YAML 1.1 reads 1e6 (no dot) as text
        try:
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise FitError(f"must be a finite number, got {value!r}", source=source, field=fld)
    return float(value)


def _check_kind(kind: ParameterKind, value: float, source: str, fld: str) -> None:
    problem = kind.check_value(value)
    if problem:
        raise FitError(problem, source=source, field=fld)


def _entry_dict(p: ParamSpec) -> dict[str, Any]:
    entry: dict[str, Any] = {"kind": p.kind.name, "target": p.target}
    if not p.free:
        entry["value"] = float(p.value)
    else:
        entry["bounds"] = [float(b) for b in p.bounds]
        if p.start is not None:
            entry["start"] = float(p.start)
    if p.scale != "linear":
        entry["scale"] = p.scale
    return entry


def save_param_file(path: str | Path, spec: ParameterSpec, header: str = "", fit: Mapping[str, Any] | None = None) -> None:
    """Write `spec` (atomically); `header` lines become comments, `fit` a record of the run."""
    data = spec.to_dict()
    if fit:
        data["fit"] = dict(fit)
    comments = "".join(f"# {line}\n" for line in header.splitlines())
    body = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=120)
    write_atomic(path, comments + body)


__all__ = ["PARAMETER_KINDS", "ParameterKind", "ParameterSpec", "ParamSpec", "Setting", "apply_params",
           "check_targets", "load_param_file", "parse_params", "register_kind", "save_param_file", "scene_setting"]
