"""Parameter kinds: how one value changes an evaluation of a trial, in an explicit, open registry.

A kind writes into the scene parameters (`SceneParams`, set in a fresh Drake context, no rebuild) and/or the
telemetry the replay drives the robot with. A new kind is one small class decorated with `@register_kind`
(docs/fit.md shows one); parameter files name kinds by `name`.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

from ..errors import FitError
from ..odb import ObjectDatabase
from ..recording.telemetry import Telemetry
from ..sim.scene import ObjectParams, SceneParams
from ..sim.shapes import mass_properties
from ..world import WorldState

TYPE_PREFIX = "type:"


# --- what a kind changes --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Setting:
    """What one evaluation of a trial runs with: the world before, scene parameters and telemetry."""

    world: WorldState
    params: SceneParams
    telemetry: Telemetry
    odb: ObjectDatabase = field(compare=False, repr=False)

    def object_params(self, name: str) -> ObjectParams:
        return self.params.objects.get(name, ObjectParams())

    def with_object(self, name: str, **changes: Any) -> "Setting":
        objects = dict(self.params.objects)
        objects[name] = replace(self.object_params(name), **changes)
        return replace(self, params=replace(self.params, objects=objects))


class ParameterKind:
    """One kind of parameter. Subclasses set `name`, `doc`, `targets` and implement `apply`.

    `targets` says what an entry's `target` names: "objects" (an object, or ``type:<type>`` for every object
    of that type), "contacts" (objects or robot links ``<robot>/<link>``), "free objects" (objects that move),
    "robot" (the robot's name) or "joints" (a telemetry joint). `minimum` is the smallest valid value and
    `strict` whether it is excluded.
    """

    name: ClassVar[str]
    doc: ClassVar[str] = ""
    unit: ClassVar[str] = ""
    targets: ClassVar[str] = "objects"
    minimum: ClassVar[float | None] = None
    strict: ClassVar[bool] = False

    def select(self, target: str, world: WorldState, odb: ObjectDatabase) -> tuple[str, ...]:
        """The names in `world` that `target` selects; () when the parameter does not concern this trial."""
        robot = world.robot.name if world.robot is not None else None
        if self.targets == "robot":
            return (target,) if target == robot else ()
        if self.targets == "joints":
            return (target,) if world.robot is not None and target in odb.get(world.robot.type).robot.joints else ()
        if self.targets == "contacts" and robot is not None and target.startswith(robot + "/"):
            return (target,)
        if target.startswith(TYPE_PREFIX):
            wanted = target[len(TYPE_PREFIX):]
            names = tuple(n for n, o in world.objects.items() if odb.get(o.type).is_a(wanted))
        else:
            names = (target,) if target in world.objects else ()
        if self.targets == "free objects":
            names = tuple(n for n in names if not odb.get(world.objects[n].type).fixed)
        return names

    def check_value(self, value: float) -> str | None:
        """Why `value` is not valid for this kind, or None."""
        if self.minimum is not None and (value < self.minimum or (self.strict and value == self.minimum)):
            return f"{self.name} must be {'>' if self.strict else '>='} {self.minimum:g}, got {value:g}"
        return None

    def apply(self, value: float, names: tuple[str, ...], setting: Setting) -> Setting:
        raise NotImplementedError

    def __reduce__(self):
        """Pickled by name: a worker process gets its own registry's instance, importing the module that
        registers the kind if it has not been imported there yet (so kinds made inside functions travel too)."""
        return (kind_named, (self.name, type(self).__module__))


PARAMETER_KINDS: dict[str, ParameterKind] = {}


def kind_named(name: str, module: str | None = None) -> ParameterKind:
    """The registered kind `name`, importing `module` first when the kind is not registered yet."""
    if name not in PARAMETER_KINDS and module:
        importlib.import_module(module)
    try:
        return PARAMETER_KINDS[name]
    except KeyError:
        raise FitError(f"unknown parameter kind {name!r}; kinds: {', '.join(sorted(PARAMETER_KINDS))} (a kind must "
                       "be registered when its module is imported)") from None


def register_kind(cls: type[ParameterKind]) -> type[ParameterKind]:
    """Add a kind to `PARAMETER_KINDS` under its `name` (a class decorator)."""
    if not getattr(cls, "name", None):
        raise FitError(f"parameter kind {cls.__name__} has no name")
    if cls.name in PARAMETER_KINDS and type(PARAMETER_KINDS[cls.name]) is not cls:
        raise FitError(f"parameter kind {cls.name!r} is registered twice ({type(PARAMETER_KINDS[cls.name]).__name__} "
                       f"and {cls.__name__})")
    PARAMETER_KINDS[cls.name] = cls()
    return cls


class _ObjectField(ParameterKind):
    """Sets one `ObjectParams` field of every selected object (or robot link)."""

    field_name: ClassVar[str]

    def apply(self, value: float, names: tuple[str, ...], setting: Setting) -> Setting:
        for name in names:
            setting = setting.with_object(name, **{self.field_name: float(value)})
        return setting


@register_kind
class Friction(_ObjectField):
    name, field_name, targets, minimum = "friction", "friction", "contacts", 0.0
    doc = "Coulomb friction (static; also dynamic unless dynamic_friction is set); Drake combines two surfaces' values"


@register_kind
class DynamicFriction(_ObjectField):
    name, field_name, targets, minimum = "dynamic_friction", "dynamic_friction", "contacts", 0.0
    doc = "dynamic Coulomb friction (kept <= the static one)"


@register_kind
class HydroelasticModulus(_ObjectField):
    name, field_name, unit, minimum, strict = "hydroelastic_modulus", "hydroelastic_modulus", "Pa", 0.0, True
    doc = "hydroelastic modulus of a compliant object (contact stiffness)"


@register_kind
class Dissipation(_ObjectField):
    name, field_name, unit, targets, minimum = "dissipation", "dissipation", "s/m", "contacts", 0.0
    doc = "Hunt-Crossley dissipation of the contact"


@register_kind
class Mass(_ObjectField):
    name, field_name, unit, targets, minimum, strict = "mass", "mass", "kg", "free objects", 0.0, True
    doc = "mass of a free object (inertia scaled with it)"


class _ComComponent(ParameterKind):
    """One coordinate of the centre of mass in the object's frame; the others stay as they are."""

    axis: ClassVar[int]
    unit, targets = "m", "free objects"

    def apply(self, value: float, names: tuple[str, ...], setting: Setting) -> Setting:
        for name in names:
            current = setting.object_params(name).com
            if current is None:
                current = tuple(float(v) for v in mass_properties(setting.odb, setting.world.objects[name].type).com)
            com = list(current)
            com[self.axis] = float(value)
            setting = setting.with_object(name, com=tuple(com))
        return setting


@register_kind
class ComX(_ComComponent):
    name, axis, doc = "com_x", 0, "centre of mass x in the object's frame"


@register_kind
class ComY(_ComComponent):
    name, axis, doc = "com_y", 1, "centre of mass y in the object's frame"


@register_kind
class ComZ(_ComComponent):
    name, axis, doc = "com_z", 2, "centre of mass z in the object's frame"


class _ForceComponent(ParameterKind):
    """A constant external force on a free object (world frame, at its centre of mass), one axis."""

    axis: ClassVar[int]
    unit, targets = "N", "free objects"

    def apply(self, value: float, names: tuple[str, ...], setting: Setting) -> Setting:
        forces = dict(setting.params.external_forces)
        for name in names:
            f = list(forces.get(name, (0.0, 0.0, 0.0)))
            f[self.axis] = float(value)
            forces[name] = tuple(f)
        return replace(setting, params=replace(setting.params, external_forces=forces))


@register_kind
class ForceX(_ForceComponent):
    name, axis, doc = "force_x", 0, "constant external force along world x"


@register_kind
class ForceY(_ForceComponent):
    name, axis, doc = "force_y", 1, "constant external force along world y"


@register_kind
class ForceZ(_ForceComponent):
    name, axis, doc = "force_z", 2, "constant external force along world z"


@register_kind
class Latency(ParameterKind):
    name, unit, targets = "latency", "s", "robot"
    doc = "the robot executes its telemetry this much later (Telemetry.shifted)"

    def apply(self, value: float, names: tuple[str, ...], setting: Setting) -> Setting:
        return replace(setting, telemetry=setting.telemetry.shifted(value)) if names else setting


@register_kind
class JointOffset(ParameterKind):
    name, targets = "joint_offset", "joints"
    doc = "a constant offset added to one joint's telemetry (calibration; rad or m)"

    def apply(self, value: float, names: tuple[str, ...], setting: Setting) -> Setting:
        offsets = {n: float(value) for n in names if n in setting.telemetry.joint_names}
        return replace(setting, telemetry=setting.telemetry.with_offsets(offsets)) if offsets else setting
