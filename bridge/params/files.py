"""Parameter files: what a fit may change, a fitted result, and the model a diagnosis found (its scene file) are
one format.

    params:
      - {kind: friction, target: big_box, bounds: [0.1, 1.0], start: 0.5}   # target: an object, or type:<type>
      - {kind: friction, target: pusher/pusher_rod, bounds: [0.05, 1.0]}    # a robot link (contact kinds only)
      - {kind: hydroelastic_modulus, target: big_box, bounds: [1e5, 1e8], start: 1e6, scale: log}
      - {kind: mass, target: big_box, bounds: [0.5, 2.0]}                   # start: middle of the bounds
      - {kind: com_x, target: big_box, value: 0.01}                         # fixed: applied, not fitted
      - {kind: obstacle_x, target: table, value: 0.62, effect: hidden_obstacle}   # effect: a label
      - {kind: friction, target: table, value: 0.47, std: 0.03}            # std: 1 sigma (bridge infer --samples)

An entry is free (`bounds`, optional `start`, optional `scale: linear|log`: how the bounds map onto the unit box)
or fixed (`value`, optionally `std`: its 1-sigma uncertainty, which `bridge infer --samples` draws from; fitted
files and scene files carry it). Entries apply in file order. `effect` says which effect of a diagnosis an entry
belongs to; it changes nothing. `fit` and `diagnosis` hold what `bridge fit` / `bridge diagnose` record about the run and
are ignored when reading. The kinds are `bridge.params.kinds.KINDS`.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping

from ..errors import ParameterError
from ..files import dump_yaml, read_yaml, write_atomic
from .kinds import KINDS, Kind
from .parameters import SPACINGS, Parameter, ParameterSet

ENTRY_KEYS = ("kind", "target", "bounds", "start", "value", "scale", "effect", "std")
FILE_KEYS = ("params", "fit", "diagnosis")


def load_param_file(path: str | Path) -> ParameterSet:
    """Read and check a parameter (or scene) file; every problem names the file and the entry."""
    path = Path(path)
    return parse_params(read_yaml(path, "parameter file", ParameterError), str(path))


def parse_params(data: Any, source: str = "<memory>") -> ParameterSet:
    if isinstance(data, dict) and "effects" in data and "params" not in data:
        raise ParameterError("this is a scene file of bridge 0.1 (an 'effects' list); scene files are parameter "
                             "files now: run bridge diagnose again to write one", source=source)
    if not isinstance(data, dict) or "params" not in data:
        raise ParameterError("a parameter file is a mapping with a 'params' list", source=source)
    unknown = sorted(set(data) - set(FILE_KEYS), key=str)
    if unknown:
        raise ParameterError(f"unknown key {unknown[0]!r}; valid keys: {', '.join(FILE_KEYS)}", source=source)
    raw = data["params"]
    if not isinstance(raw, list) or not raw:
        raise ParameterError("must be a non-empty list of {kind, target, bounds | value, ...} entries", source=source,
                             field="params")
    entries = tuple(_parse_entry(body, source, f"params[{i}]") for i, body in enumerate(raw))
    seen: dict[str, int] = {}
    for i, p in enumerate(entries):
        if p.name in seen:
            raise ParameterError(f"{p.name} is given twice (also params[{seen[p.name]}])", source=source,
                                 field=f"params[{i}]")
        seen[p.name] = i
    return ParameterSet(entries, source)


def _parse_entry(body: Any, source: str, fld: str) -> Parameter:
    if not isinstance(body, dict):
        raise ParameterError("must be a mapping {kind, target, bounds, start} or {kind, target, value}", source=source,
                             field=fld)
    unknown = sorted(set(body) - set(ENTRY_KEYS), key=str)
    if unknown:
        raise ParameterError(f"unknown key {unknown[0]!r}; valid keys: {', '.join(ENTRY_KEYS)}", source=source,
                             field=fld)
    for key in ("kind", "target"):
        if key not in body:
            raise ParameterError(f"missing field {key!r}", source=source, field=fld)
    kind_name = body["kind"]
    if kind_name not in KINDS:
        raise ParameterError(f"unknown kind {kind_name!r}; kinds: {', '.join(KINDS)}", source=source,
                             field=f"{fld}.kind")
    kind = KINDS[kind_name]
    target = body["target"]
    if not isinstance(target, str) or not target.strip():
        raise ParameterError(f"must be an object name, type:<type>, a robot link or a joint, got {target!r}",
                             source=source, field=f"{fld}.target")
    spacing = body.get("scale", "linear")
    if spacing not in SPACINGS:
        raise ParameterError(f"scale {spacing!r} is not one of {', '.join(SPACINGS)}", source=source,
                             field=f"{fld}.scale")
    effect = body.get("effect", "")
    if not isinstance(effect, str):
        raise ParameterError(f"must be an effect's name, got {effect!r}", source=source, field=f"{fld}.effect")
    if "value" in body:
        if "bounds" in body or "start" in body:
            raise ParameterError("give 'value' (fixed) or 'bounds' and 'start' (fitted), not both", source=source,
                                 field=fld)
        value = _number(body["value"], source, f"{fld}.value")
        _check_kind(kind, value, source, f"{fld}.value")
        std = None
        if body.get("std") is not None:
            std = _number(body["std"], source, f"{fld}.std")
            if std < 0:
                raise ParameterError(f"a standard deviation is >= 0, got {std:g}", source=source, field=f"{fld}.std")
        return Parameter(kind, target, value=value, spacing=spacing, effect=effect, std=std)
    if "std" in body:
        raise ParameterError("'std' is the uncertainty of a fixed 'value'; a fitted entry has bounds instead",
                             source=source, field=f"{fld}.std")
    if "bounds" not in body:
        raise ParameterError("missing field 'bounds' (a fitted parameter) or 'value' (a fixed one)", source=source,
                             field=fld)
    bounds = body["bounds"]
    if not isinstance(bounds, (list, tuple)) or len(bounds) != 2:
        raise ParameterError(f"must be two numbers [low, high], got {bounds!r}", source=source, field=f"{fld}.bounds")
    lo, hi = (_number(b, source, f"{fld}.bounds[{k}]") for k, b in enumerate(bounds))
    if not lo < hi:
        raise ParameterError(f"bounds must increase (low < high), got [{lo:g}, {hi:g}]", source=source,
                             field=f"{fld}.bounds")
    for k, b in enumerate((lo, hi)):
        _check_kind(kind, b, source, f"{fld}.bounds[{k}]")
    if spacing == "log" and lo <= 0:
        raise ParameterError(f"a log scale needs bounds > 0, got [{lo:g}, {hi:g}]", source=source,
                             field=f"{fld}.bounds")
    start = None
    if "start" in body and body["start"] is not None:
        start = _number(body["start"], source, f"{fld}.start")
        if not lo <= start <= hi:
            raise ParameterError(f"start {start:g} is outside the bounds [{lo:g}, {hi:g}]", source=source,
                                 field=f"{fld}.start")
    return Parameter(kind, target, bounds=(lo, hi), start=start, spacing=spacing, effect=effect)


def _number(value: Any, source: str, fld: str) -> float:
    if isinstance(value, str):  # YAML 1.1 reads 1e6 (no dot) as text
        try:
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ParameterError(f"must be a finite number, got {value!r}", source=source, field=fld)
    return float(value)


def _check_kind(kind: Kind, value: float, source: str, fld: str) -> None:
    problem = kind.check_value(value)
    if problem:
        raise ParameterError(problem, source=source, field=fld)


def entry_dict(p: Parameter) -> dict[str, Any]:
    entry: dict[str, Any] = {"kind": p.kind.name, "target": p.target}
    if not p.free:
        entry["value"] = float(f"{p.value:.10g}")
        if p.std is not None:
            entry["std"] = float(f"{p.std:.4g}")
    else:
        entry["bounds"] = [float(b) for b in p.bounds]
        if p.start is not None:
            entry["start"] = float(p.start)
    if p.spacing != "linear":
        entry["scale"] = p.spacing
    if p.effect:
        entry["effect"] = p.effect
    return entry


def save_param_file(path: str | Path, parameters: ParameterSet, header: str = "",
                    record: Mapping[str, Mapping[str, Any]] | None = None) -> Path:
    """Write `parameters` (atomically); `header` lines become comments, `record` ({"fit": ...} or
    {"diagnosis": ...}) what the run that wrote it records."""
    write_atomic(path, param_file_text(parameters, header, record), ParameterError)
    return Path(path)


def param_file_text(parameters: ParameterSet, header: str = "",
                    record: Mapping[str, Mapping[str, Any]] | None = None) -> str:
    """What `save_param_file` writes (a report publishes it with its other files as one set)."""
    data = parameters.to_dict()
    for key, value in (record or {}).items():
        if key not in FILE_KEYS[1:]:
            raise ParameterError(f"a parameter file records 'fit' or 'diagnosis', not {key!r}")
        data[key] = dict(value)
    comments = "".join(f"# {line}\n" for line in header.splitlines())
    return comments + dump_yaml(data)
