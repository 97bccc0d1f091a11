"""Parameter kinds: how one value changes what is simulated. The one vocabulary of parameters: parameter files
(`bridge fit --params`, `bridge infer --params`), the fits, the diagnosis' effects (each a bundle of kinds) and
the scene files it writes all name these.

A kind changes a `Rollout` (`bridge.rollout`): scene values written into a Drake context (no rebuild), the
telemetry the robot follows, the world's poses (a tilted surface: a new scene), or extra geometry (a post, a
sheet of another material: a new scene). Kinds whose values act together (a post's x and y, a tilt's two slopes
and height) belong to a `Family`: their values are collected and the family builds one thing from all of them,
the missing ones at their null values.

Besides `apply`, a kind says what a search needs to start from the world model: its `null` value (what the
world model has: no change), the `bounds` a search explores, a typical `step` (the unit of normalised coordinates
and the finite-difference step) and, where it has one, the departure from null below which it makes no
difference worth reporting (`negligible`).

Apart from those, a kind says which values are possible at all, to refuse a value a user gives (a parameter or
scene file) before it is simulated into a wrong world state: `physical`, a range checked where a file is read
(`check_value`), and `check_on`, what a value must satisfy in one recording (a latency well inside the telemetry,
a centre of mass inside the body, a mass of the order of the object database's). The bounds of a search lie
inside both; docs/fit.md lists the ranges and why.

`KINDS` is the registry, spelled out at the bottom of this file; parameter files name kinds by `name`.
"""
from __future__ import annotations

import math
from typing import ClassVar, Mapping

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ParameterError
from ..odb import ObjectDatabase
from ..odb.geometry import support, z_range
from ..odb.ranges import DISSIPATION, FRICTION, HYDROELASTIC_MODULUS, MASS, PhysicalRange
from ..rollout.rollout import Rollout
from ..sim.extras import ObjectScale, SurfacePatch, WeldedShape
from ..sim.shapes import mass_properties
from ..sim.anisotropy import AnisotropicFriction, FrictionField, RateFriction
from ..sim.friction import combined_friction, pair_coefficients
from ..sim.support import SupportPressure
from ..values import GRAVITY, Pose
from ..world import WorldState
from .surfaces import footprint_half, movable_objects, support_of, supported_by, surface_top

TYPE_PREFIX = "type:"
OBSTACLE_RADIUS = 0.015  # m: the post `obstacle_x`/`obstacle_y` place, unless `obstacle_radius` says
OBSTACLE_FRICTION = 0.5  # the post's own coefficient unless `obstacle_mu` says (Drake combines it with the object's)
PATCH_RAISED = 1.0e-6  # m: the sheet carries what stands on it (objects sink ~0.6 um), its edge is no step
ANY = PhysicalRange(-math.inf, math.inf, why="any finite number")
MASS_RATIO = 100.0  # a mass more than this many times the object database's (or less than its share) is another object
FORCE_WEIGHTS = 10.0  # a constant hidden force above this many times the object's weight throws it off the table
LATENCY_SHARE = 0.5  # a latency shifts this share of the telemetry out of the replay at most
# a friction coefficient (or the factor on a robot's pairs) within this share of the object database's changes nothing
# a user would act on: repeated measurements of one material pair scatter by more (as 5 % of mass, `Mass.negligible`)
NEGLIGIBLE_FRICTION = 0.05
RATE_SPEED = 0.02  # m/s: `rate_speed`'s null, a Stribeck speed of dry contact (millimetres to centimetres a second)


class Kind:
    """One kind of parameter. Subclasses set `name`, `doc`, `unit`, `targets` and implement `apply` (or, in a
    family, `component`) and `null`.

    `targets` says what a setting's `target` names: "objects" (an object, or ``type:<type>`` for every object of
    that type), "contacts" (objects or robot links ``<robot>/<link>``), "free objects" (objects that move),
    "surfaces" (fixtures), "robot" (the robot's name) or "joints" (a telemetry joint). `physical` is the range
    of values possible at all (`bridge.odb.ranges`), `check_on` what a value must satisfy in one recording.
    """

    name: ClassVar[str]
    doc: ClassVar[str] = ""
    unit: ClassVar[str] = ""
    targets: ClassVar[str] = "objects"
    physical: ClassVar[PhysicalRange] = ANY
    family: ClassVar["type[Family] | None"] = None
    # applied at its null value, the kind reproduces the world model exactly (`model.canonical_model` drops such
    # settings, so a search's point with an effect at null is the model without it); False where it does not (a
    # friction coefficient also sets the dynamic one, a post at its null place is still a post)
    null_is_world: ClassVar[bool] = False
    inert_without: ClassVar[str | None] = None  # a kind that changes nothing unless this kind is set too
    # how the simulator makes contact (stiffness, damping), not a property of the world a user asks about: a
    # diagnosis may fit it among the ordinary parameters (`identify.Options.contact`), and its bounds are states
    # a contact can take (no damping), so a fit pressing on one says nothing about the model family
    # (`search.FitResult.at_bound`)
    contact_model: ClassVar[bool] = False

    def select(self, target: str, world: WorldState, odb: ObjectDatabase) -> tuple[str, ...]:
        """The names in `world` that `target` selects; () when it names nothing there."""
        robot = world.robot.name if world.robot is not None else None
        if self.targets == "robot":
            return (target,) if target == robot else ()
        if self.targets == "joints":
            return (target,) if world.robot is not None and target in odb.get(world.robot.type).robot.joints else ()
        if self.targets == "contacts" and robot is not None and target.startswith(robot + "/"):
            spec = odb.get(world.robot.type).robot  # a link the model lacks (or one nothing can touch) names nothing
            return (target,) if not spec.links or target[len(robot) + 1:] in spec.contact_links else ()
        if target.startswith(TYPE_PREFIX):
            wanted = target[len(TYPE_PREFIX):]
            names = tuple(n for n, o in world.objects.items() if odb.get(o.type).is_a(wanted))
        else:
            names = (target,) if target in world.objects else ()
        if self.targets == "free objects":
            names = tuple(n for n in names if not odb.get(world.objects[n].type).fixed)
        if self.targets == "surfaces":
            names = tuple(n for n in names if odb.get(world.objects[n].type).fixed)
        return names

    def valid_targets(self, worlds, odb: ObjectDatabase) -> str:
        """What a target of this kind could name in `worlds`, for error messages."""
        robots = sorted({w.robot.name for w in worlds if w.robot is not None})
        if self.targets == "robot":
            return f"{self.name} targets the robot: {', '.join(robots) or 'none in the recordings'}"
        if self.targets == "joints":
            joints = sorted({j for w in worlds if w.robot is not None for j in odb.get(w.robot.type).robot.joints})
            return f"{self.name} targets a joint: {', '.join(joints) or 'none in the recordings'}"
        fixed = {"free objects": False, "surfaces": True}.get(self.targets)
        objects = sorted({n for w in worlds for n, o in w.objects.items()
                          if fixed is None or odb.get(o.type).fixed == fixed})
        types = sorted({o.type for w in worlds for o in w.objects.values()})
        text = f"objects: {', '.join(objects)}; or type:<type> with a type among {', '.join(types)}"
        if self.targets == "contacts" and robots:
            links = sorted({f"{w.robot.name}/{link}" for w in worlds if w.robot is not None
                            for link in odb.get(w.robot.type).robot.contact_links})
            text += f"; or a robot link with collision geometry: {', '.join(links) or '<robot>/<link>'}"
        return text

    def check_value(self, value: float) -> str | None:
        """Why `value` is not possible for this kind anywhere (outside `physical`), or None."""
        return self.physical.problem(value, self.name)

    def check_on(self, value: float, names: tuple[str, ...], rollout: Rollout, odb: ObjectDatabase) -> str | None:
        """Why `value` on `names` (what a target selects in the rollout's world) is not possible in this recording,
        or None. Checked for the values a user gives, before a replay (`bridge.params.check_values`)."""
        return None

    def apply(self, value: float, names: tuple[str, ...], rollout: Rollout, odb: ObjectDatabase) -> Rollout:
        raise NotImplementedError

    # --- where a search starts ----------------------------------------------------------------------------
    def null(self, world: WorldState, odb: ObjectDatabase, target: str) -> float | None:
        """The world model's value (None when the world model does not say, e.g. a robot link's friction)."""
        raise NotImplementedError

    def bounds(self, world: WorldState, odb: ObjectDatabase, target: str) -> tuple[float, float]:
        raise NotImplementedError

    def step(self, world: WorldState, odb: ObjectDatabase, target: str) -> float:
        raise NotImplementedError

    def negligible(self, world: WorldState, odb: ObjectDatabase, target: str) -> float | None:
        return None

    def __repr__(self) -> str:
        return f"<kind {self.name}>"


def _times(ratio: float) -> str:
    """'300 times', '0.004 times': a ratio for a message."""
    return f"{ratio:.0f} times" if ratio >= 10 else f"{ratio:.2g} times"


def _type_name(world: WorldState, odb: ObjectDatabase, target: str) -> str:
    if target.startswith(TYPE_PREFIX):
        return target[len(TYPE_PREFIX):]
    if target not in world.objects:
        raise ParameterError(f"no object {target!r} in world {world.name!r}; objects: {', '.join(world.objects)}")
    return world.objects[target].type


# --- scene values: contact -------------------------------------------------------------------------------------
class _ObjectField(Kind):
    """Sets one `ObjectValues` field of every selected object (or robot link)."""

    field_name: ClassVar[str]

    def apply(self, value, names, rollout, odb):
        values = rollout.values
        for name in names:
            values = values.with_object(name, **{self.field_name: float(value)})
        return rollout.with_values(values)


class Friction(_ObjectField):
    name, field_name, targets, physical = "friction", "friction", "contacts", FRICTION
    doc = "Coulomb friction (static; also dynamic unless dynamic_friction is set); Drake combines two surfaces' values"

    def null(self, world, odb, target):
        if world.robot is not None and target.startswith(world.robot.name + "/"):
            return link_friction(world, odb).get(target)  # the model file's, when it gives one
        return odb.get(_type_name(world, odb, target)).physics.friction

    def bounds(self, world, odb, target):
        return 0.02, max(1.5, 3 * (self.null(world, odb, target) or 0.5))

    def step(self, world, odb, target):
        return 0.3 * (self.null(world, odb, target) or 0.5)

    def negligible(self, world, odb, target):
        return NEGLIGIBLE_FRICTION * (self.null(world, odb, target) or 0.5)


class DynamicFriction(Friction):
    name, field_name = "dynamic_friction", "dynamic_friction"
    doc = "dynamic Coulomb friction (kept <= the static one)"

    def null(self, world, odb, target):
        if world.robot is not None and target.startswith(world.robot.name + "/"):
            return link_friction(world, odb).get(target)
        return odb.get(_type_name(world, odb, target)).physics.mu_dynamic


def link_friction(world: WorldState, odb: ObjectDatabase) -> dict[str, float]:
    """The robot's links' dynamic coefficients as its model file gives them, by 'robot/link'."""
    if world.robot is None:
        return {}
    return {f"{world.robot.name}/{link}": mu for link, mu in odb.get(world.robot.type).robot.link_friction}


def current_friction(rollout: Rollout, odb: ObjectDatabase, name: str) -> float | None:
    """The dynamic coefficient `name` (an object or 'robot/link') has in `rollout`: its scene values', else the
    object database's or the robot model's (None when neither says)."""
    set_ = rollout.values.objects.get(name)
    if set_ is not None and (set_.dynamic_friction is not None or set_.friction is not None):
        return set_.dynamic_friction if set_.dynamic_friction is not None else set_.friction
    if name in rollout.world.objects:
        return odb.get(rollout.world.objects[name].type).physics.mu_dynamic
    return link_friction(rollout.world, odb).get(name)


class Dissipation(_ObjectField):
    null_is_world = True
    contact_model = True
    name, field_name, unit, targets, physical = "dissipation", "dissipation", "s/m", "contacts", DISSIPATION
    doc = "Hunt-Crossley dissipation of the contact"

    def null(self, world, odb, target):
        if world.robot is not None and target.startswith(world.robot.name + "/"):
            return None
        return odb.get(_type_name(world, odb, target)).physics.dissipation

    def bounds(self, world, odb, target):
        return 0.0, 10.0 * max(self.null(world, odb, target) or 1.0, 0.1)

    def step(self, world, odb, target):
        return 0.3 * max(self.null(world, odb, target) or 1.0, 0.1)


class HydroelasticModulus(_ObjectField):
    null_is_world = True
    contact_model = True
    name, field_name, unit, physical = "hydroelastic_modulus", "hydroelastic_modulus", "Pa", HYDROELASTIC_MODULUS
    doc = "hydroelastic modulus of a compliant object (contact stiffness)"

    def null(self, world, odb, target):
        return odb.get(_type_name(world, odb, target)).physics.hydroelastic_modulus

    def bounds(self, world, odb, target):
        e = self.null(world, odb, target) or 1e7
        return 0.01 * e, 100.0 * e

    def step(self, world, odb, target):
        return 0.5 * (self.null(world, odb, target) or 1e7)


# --- scene values: mass --------------------------------------------------------------------------------------
class Mass(_ObjectField):
    null_is_world = True
    name, field_name, unit, targets, physical = "mass", "mass", "kg", "free objects", MASS
    doc = "mass of a free object (its rotational inertia follows as mass_spread says: by default scaled with it)"

    def check_on(self, value, names, rollout, odb):
        for name in names:
            known = float(mass_properties(odb, rollout.world.objects[name].type).mass)
            if not known / MASS_RATIO <= value <= known * MASS_RATIO:
                return (f"mass {value:g} kg is {_times(value / known)} the {known:g} kg of {name!r} in the object "
                        f"database, at most {MASS_RATIO:g} times more or less: another object, or not in kg")
        return None

    def null(self, world, odb, target):
        return float(mass_properties(odb, _type_name(world, odb, target)).mass)

    def bounds(self, world, odb, target):
        m = self.null(world, odb, target)
        return 0.2 * m, 5.0 * m

    def step(self, world, odb, target):
        return 0.3 * self.null(world, odb, target)

    def negligible(self, world, odb, target):
        return 0.05 * self.null(world, odb, target)


class MassSpread(_ObjectField):
    inert_without = "mass"  # the inertia scales by 1 + spread (mass / database mass - 1)
    name, field_name, targets = "mass_spread", "spread", "free objects"
    physical = PhysicalRange(0.0, 3.0, "", "0 puts a changed mass at the centre of mass, 1 spreads it like the "
                             "object's own, 3 at a box's corners")
    doc = ("where a changed mass sits: 1 spread like the object's own (uniform density: the rotational inertia "
           "scales with the mass), 0 at the centre of mass (a compact weight inside: the inertia stays)")

    def null(self, world, odb, target):
        return 1.0

    def bounds(self, world, odb, target):
        return 0.0, 1.5

    def step(self, world, odb, target):
        return 0.5


class _ComComponent(Kind):
    """One coordinate of the centre of mass in the object's frame; the others stay as they are."""
    null_is_world = True

    axis: ClassVar[int]
    unit, targets = "m", "free objects"
    physical = PhysicalRange(-1.0, 1.0, "m", "in m: no object on a table reaches 1 m from its own origin")

    def check_on(self, value, names, rollout, odb):
        for name in names:
            geometry = odb.get(rollout.world.objects[name].type).geometry
            if geometry is None or (geometry.shape == "mesh" and geometry.mesh is None):
                continue  # a mesh of a dataset not given: reported when the scene is built
            e = np.eye(3)[self.axis]
            lo, hi = -support(geometry, Pose(), -e), support(geometry, Pose(), e)
            if not lo - 1e-9 <= value <= hi + 1e-9:
                return (f"{self.name} {value:g} m is outside {name!r} ([{lo:.4g}, {hi:.4g}] m along its "
                        f"{'xyz'[self.axis]}): a centre of mass lies within the body")
        return None

    def apply(self, value, names, rollout, odb):
        values = rollout.values
        for name in names:
            current = values.objects[name].com if name in values.objects else None
            com = list(current if current is not None else
                       (float(v) for v in mass_properties(odb, rollout.world.objects[name].type).com))
            com[self.axis] = float(value)
            values = values.with_object(name, com=tuple(com))
        return rollout.with_values(values)

    def null(self, world, odb, target):
        return float(mass_properties(odb, _type_name(world, odb, target)).com[self.axis])

    def _half(self, world, odb, target) -> float:
        return float(footprint_half(world, odb, target)[self.axis]) if target in world.objects else 0.05

    def bounds(self, world, odb, target):
        c, h = self.null(world, odb, target), self._half(world, odb, target)
        return c - 0.6 * h, c + 0.6 * h

    def step(self, world, odb, target):
        return 0.1 * self._half(world, odb, target)

    def negligible(self, world, odb, target):
        return 0.001


class ComX(_ComComponent):
    name, axis, doc = "com_x", 0, "centre of mass x in the object's frame"


class ComY(_ComComponent):
    name, axis, doc = "com_y", 1, "centre of mass y in the object's frame"


class ComZ(_ComComponent):
    name, axis, doc = "com_z", 2, "centre of mass z in the object's frame"


class _ForceComponent(Kind):
    """A constant external force on a free object (world frame, at its centre of mass), one axis."""
    null_is_world = True

    axis: ClassVar[int]
    unit, targets = "N", "free objects"
    physical = PhysicalRange(-1000.0, 1000.0, "N", "in N: 1000 N is the weight of 100 kg")

    def check_on(self, value, names, rollout, odb):
        for name in names:
            weight = self._weight(rollout.world, odb, name)
            if abs(value) > FORCE_WEIGHTS * weight:
                return (f"{self.name} {value:g} N is {_times(abs(value) / weight)} the weight of {name!r} "
                        f"({weight:.3g} N; at most {FORCE_WEIGHTS:g}): it would throw the object off the table")
        return None

    def apply(self, value, names, rollout, odb):
        values = rollout.values
        for name in names:
            f = list(values.external_forces.get(name, (0.0, 0.0, 0.0)))
            f[self.axis] = float(value)
            values = values.with_force(name, tuple(f))
        return rollout.with_values(values)

    def null(self, world, odb, target):
        return 0.0

    def _weight(self, world, odb, target) -> float:
        return float(mass_properties(odb, _type_name(world, odb, target)).mass) * GRAVITY

    def bounds(self, world, odb, target):
        w = self._weight(world, odb, target)
        return -w, w

    def step(self, world, odb, target):
        return 0.05 * self._weight(world, odb, target)


class ForceX(_ForceComponent):
    name, axis, doc = "force_x", 0, "constant external force along world x"


class ForceY(_ForceComponent):
    name, axis, doc = "force_y", 1, "constant external force along world y"


class ForceZ(_ForceComponent):
    name, axis, doc = "force_z", 2, "constant external force along world z"


# --- telemetry ----------------------------------------------------------------------------------------------
class Latency(Kind):
    null_is_world = True
    name, unit, targets = "latency", "s", "robot"
    doc = "the robot moved this much later than its telemetry says (Telemetry.shifted)"
    physical = PhysicalRange(-2.0, 2.0, "s", "teleoperation latencies are tens to hundreds of milliseconds; "
                             "latency is in seconds: 120 ms is 0.12")

    def check_on(self, value, names, rollout, odb):
        tel = rollout.telemetry
        if tel is None or abs(value) <= LATENCY_SHARE * tel.duration:
            return None
        return (f"latency {value:g} s would shift the robot's motion out of the {tel.duration:.3g} s telemetry "
                f"{tel.source}: at most {LATENCY_SHARE:g} of it, {LATENCY_SHARE * tel.duration:.3g} s; latency is "
                "in seconds, 120 ms is 0.12")

    def apply(self, value, names, rollout, odb):
        return rollout.with_telemetry(rollout.telemetry.shifted(float(value))) if value else rollout

    def null(self, world, odb, target):
        return 0.0

    def bounds(self, world, odb, target):
        return -0.3, 0.3

    def step(self, world, odb, target):
        return 0.03

    def negligible(self, world, odb, target):
        return 0.005


class JointOffset(Kind):
    null_is_world = True
    name, targets = "joint_offset", "joints"
    doc = "a constant offset added to one joint's telemetry (calibration; m or rad)"
    physical = PhysicalRange(-math.pi, math.pi, "", "rad or m: a calibration offset beyond half a turn is another zero")

    def check_on(self, value, names, rollout, odb):
        spec = odb.get(rollout.world.robot.type).robot
        for name in names:
            lo, hi = spec.limits.get(name, (-math.inf, math.inf))
            if abs(value) > hi - lo:
                return (f"joint_offset {value:g} on {name!r} is more than the joint's whole range [{lo:g}, {hi:g}] "
                        f"in {spec.model.name}: no calibration error")
        return None

    def apply(self, value, names, rollout, odb):
        offsets = {n: float(value) for n in names if n in rollout.telemetry.joint_names and value}
        return rollout.with_telemetry(rollout.telemetry.with_offsets(offsets)) if offsets else rollout

    def _prismatic(self, world, odb, target) -> bool:
        return odb.get(world.robot.type).robot.joint_type.get(target) == "prismatic"

    def null(self, world, odb, target):
        return 0.0

    def bounds(self, world, odb, target):
        return (-0.03, 0.03) if self._prismatic(world, odb, target) else (-0.2, 0.2)

    def step(self, world, odb, target):
        return 0.002 if self._prismatic(world, odb, target) else 0.01

    def negligible(self, world, odb, target):
        return 0.0005 if self._prismatic(world, odb, target) else 0.002


# --- families: values that act together ------------------------------------------------------------------------
class Family:
    """Kinds whose values build one thing together. `members` maps each component to its kind's name."""

    name: ClassVar[str]
    members: ClassVar[Mapping[str, str]]

    @classmethod
    def realise(cls, values: Mapping[str, float], target: str, rollout: Rollout, odb: ObjectDatabase) -> Rollout:
        raise NotImplementedError


class _Member(Kind):
    """A component of a family: `apply` is never called alone (see `bridge.params.model.apply_model`)."""

    component: ClassVar[str]
    targets = "surfaces"

    def apply(self, value, names, rollout, odb):
        return self.family.realise({self.component: float(value)}, names[0], rollout, odb)


class PairFriction(Family):
    """The friction coefficients of a free object's pairs (Drake's combined values, what the solver uses): with the
    fixture it rests on (`sliding`) and with the robot's links (`robot`, a factor on each link's pair, since the
    links differ). Realised as per-body coefficients (`sim.friction.pair_coefficients`): the partners' are chosen
    to give the pairs and the object keeps its own unless a pair needs more. Why: per-body coefficients tie the
    pairs together (the object's coefficient enters both), so a fit of them trades one pair against the other;
    the pairs are what the physics has. What it changes besides: the support's coefficient with other objects on
    it and the links' with other objects (and, when the object's own is raised, its pairs with other objects)."""

    name = "pair_friction"
    members = {"sliding": "sliding_friction", "robot": "robot_friction"}

    @classmethod
    def realise(cls, values, target, rollout, odb):
        b0 = current_friction(rollout, odb, target)
        wanted: dict[str, float] = {}
        surface = support_of(rollout.world, odb, target)
        if surface is not None and "sliding" in values:
            wanted[surface] = values["sliding"]
        if "robot" in values:
            for link in link_friction(rollout.world, odb):
                wanted[link] = values["robot"] * combined_friction(b0, current_friction(rollout, odb, link))
        if not wanted:
            return rollout
        b, partners = pair_coefficients(b0, list(wanted.values()))
        out = rollout.values
        if b != b0:
            out = out.with_object(target, friction=b, dynamic_friction=b)
        for name, mu in zip(wanted, partners):
            out = out.with_object(name, friction=mu, dynamic_friction=mu)
        return rollout.with_values(out)


class _PairMember(_Member):
    family, targets = PairFriction, "free objects"

    def check_on(self, value, names, rollout, odb):
        if self.component == "sliding" and support_of(rollout.world, odb, names[0]) is None:
            return f"{names[0]!r} rests on no fixture: it has no sliding pair"
        if self.component == "robot" and not link_friction(rollout.world, odb):
            robot = rollout.world.robot
            return ("the world has no robot" if robot is None else
                    f"the model file of robot {robot.name!r} gives no link a friction coefficient (drake:mu_dynamic)")
        return None


class SlidingFriction(_PairMember):
    name, component, physical = "sliding_friction", "sliding", FRICTION
    doc = ("a free object's friction coefficient with the fixture it rests on (the pair's, as Drake combines "
           "them): the fixture's coefficient is set to give it")

    def null(self, world, odb, target):
        rollout = Rollout(world, None)
        surface = support_of(world, odb, target)
        own = current_friction(rollout, odb, target)
        return combined_friction(own, current_friction(rollout, odb, surface)) if surface is not None else own

    def bounds(self, world, odb, target):
        return 0.02, max(1.5, 3 * self.null(world, odb, target))

    def step(self, world, odb, target):
        return 0.3 * self.null(world, odb, target)

    def negligible(self, world, odb, target):
        return NEGLIGIBLE_FRICTION * self.null(world, odb, target)


class RobotFriction(_PairMember):
    name, component = "robot_friction", "robot"
    physical = PhysicalRange(0.0, 20.0, "", "a factor on the model's pair coefficients: 20 times a link's pair is "
                             "beyond any material pair", open_low=True)
    doc = ("a free object's friction with the robot's links, as a factor on each link's pair coefficient (the "
           "model's, as Drake combines them): the links' coefficients are set to give it")

    def null(self, world, odb, target):
        return 1.0

    def bounds(self, world, odb, target):
        return 0.1, 6.0

    def step(self, world, odb, target):
        return 0.3

    def negligible(self, world, odb, target):
        return NEGLIGIBLE_FRICTION


def tilted_poses(world: WorldState, odb: ObjectDatabase, surface: str, slope_x: float, slope_y: float,
                 dz: float = 0.0) -> dict[str, Pose]:
    """New poses of the surface and the free objects on it: tilted about the top above its centre so that it
    slopes downhill along (slope_x, slope_y), raised by dz; the objects keep their x, y on the tilted top."""
    theta = math.hypot(slope_x, slope_y)
    if theta == 0.0 and dz == 0.0:
        return {}
    R = Rotation.from_rotvec(np.array([-slope_y, slope_x, 0.0])) if theta > 0 else Rotation.identity()
    s = world.objects[surface]
    pivot = np.array([s.pose.xyz[0], s.pose.xyz[1], surface_top(world, odb, surface)])
    out = {}
    for name in (surface, *supported_by(world, odb, surface)):
        pose = world.objects[name].pose
        xyz = R.apply(np.asarray(pose.xyz) - pivot) + pivot + np.array([0.0, 0.0, dz])
        if name != surface:  # stay at the same x, y: slide up or down the slope to it
            n = R.apply([0.0, 0.0, 1.0])
            shift = np.asarray(pose.xyz[:2]) - xyz[:2]
            xyz = np.array([pose.xyz[0], pose.xyz[1], xyz[2] - (n[0] * shift[0] + n[1] * shift[1]) / n[2]])
        Rm = R.as_matrix() @ pose.rotation()
        out[name] = Pose.from_matrix(np.vstack([np.column_stack([Rm, xyz]), [0.0, 0.0, 0.0, 1.0]]))
    return out


class SurfaceTilt(Family):
    """The support fixture and what stands on it rotated (and raised): a new scene per value."""

    name = "surface_tilt"
    members = {"slope_x": "surface_slope_x", "slope_y": "surface_slope_y", "dz": "surface_dz"}

    @classmethod
    def realise(cls, values, target, rollout, odb):
        poses = tilted_poses(rollout.world, odb, target, values.get("slope_x", 0.0), values.get("slope_y", 0.0),
                             values.get("dz", 0.0))
        return rollout.with_world(rollout.world.with_poses(poses)) if poses else rollout


class _Slope(_Member):
    null_is_world = True
    family, unit = SurfaceTilt, "rad"
    physical = PhysicalRange(-0.5, 0.5, "rad", "in rad: tilted by 0.5 rad, 29 deg, a surface sheds what stands on "
                             "it, a different scene rather than a level one slightly off")

    def null(self, world, odb, target):
        return 0.0

    def bounds(self, world, odb, target):
        return -0.15, 0.15

    def step(self, world, odb, target):
        return 0.01

    def negligible(self, world, odb, target):
        return 0.0017


class SurfaceSlopeX(_Slope):
    name, component = "surface_slope_x", "slope_x"
    doc = "surface tilt: downhill slope along world x (the fixture and what stands on it rotated)"


class SurfaceSlopeY(_Slope):
    name, component = "surface_slope_y", "slope_y"
    doc = "surface tilt: downhill slope along world y (the fixture and what stands on it rotated)"


class SurfaceDz(_Member):
    null_is_world = True
    name, component, family, unit = "surface_dz", "dz", SurfaceTilt, "m"
    doc = "surface tilt: height change of the top above the fixture's centre"
    physical = PhysicalRange(-0.1, 0.1, "m", "in m: a surface 10 cm off its modelled height is another scene")

    def null(self, world, odb, target):
        return 0.0

    def bounds(self, world, odb, target):
        return -0.01, 0.01

    def step(self, world, odb, target):
        return 0.001


def _extent(world: WorldState, odb: ObjectDatabase, target: str) -> tuple[float, float, float, float]:
    """(cx, cy, hx, hy) of a fixture's top."""
    hx, hy, _ = footprint_half(world, odb, target)
    cx, cy = world.objects[target].pose.xyz[:2]
    return float(cx), float(cy), float(hx), float(hy)


class Obstacle(Family):
    """A welded upright post of radius `radius` (default `OBSTACLE_RADIUS`) at (x, y) on the surface, taller than
    anything on it, with its own friction coefficient `mu` (an unseen obstacle's surface is as unknown as its place:
    whether an object slides past it or pivots on it depends on that coefficient; and its size, where a push that
    passes beside it says whether it touches)."""

    name = "hidden_obstacle"
    members = {"x": "obstacle_x", "y": "obstacle_y", "mu": "obstacle_mu", "radius": "obstacle_radius"}

    @classmethod
    def realise(cls, values, target, rollout, odb):
        world = rollout.world
        top = surface_top(world, odb, target)
        cx, cy, hx, hy = _extent(world, odb, target)
        x, y = values.get("x", cx + hx), values.get("y", cy + hy)
        tallest = max([z_range(odb.get(world.objects[n].type).geometry, world.objects[n].pose)[1]
                       for n in movable_objects(world, odb)] + [top + 0.05])
        height = tallest - top + 0.05
        radius = values.get("radius", OBSTACLE_RADIUS)
        return rollout.with_extras(WeldedShape("hidden_obstacle", "cylinder", (radius, height), (x, y, top + height / 2),
                                               friction=values.get("mu", OBSTACLE_FRICTION)))


class _Place(_Member):
    """A coordinate on a fixture's top (`axis` 0: world x, 1: y), within its extent."""

    unit, axis = "m", 0

    def check_on(self, value, names, rollout, odb):
        for name in names:
            c, h = self._along(rollout.world, odb, name)
            if not c - h - 1e-9 <= value <= c + h + 1e-9:
                return (f"{self.name} {value:g} m is off the top of {name!r} ([{c - h:.4g}, {c + h:.4g}] m along "
                        f"world {'xy'[self.axis]})")
        return None

    def _along(self, world, odb, target) -> tuple[float, float]:
        """The top's centre and half extent along the axis."""
        cx, cy, hx, hy = _extent(world, odb, target)
        return (cx, hx) if self.axis == 0 else (cy, hy)

    def bounds(self, world, odb, target):
        c, h = self._along(world, odb, target)
        return c - h, c + h


class _ObstacleAxis(_Place):
    family = Obstacle

    def null(self, world, odb, target):  # out of the way: the far corner
        return sum(self._along(world, odb, target))

    def step(self, world, odb, target):
        return 0.005


class ObstacleX(_ObstacleAxis):
    name, component, axis, doc = "obstacle_x", "x", 0, "a post the world model lacks: its centre, world x"


class ObstacleY(_ObstacleAxis):
    name, component, axis, doc = "obstacle_y", "y", 1, "a post the world model lacks: its centre, world y"


class ObstacleMu(_Member):
    name, component, family, physical = "obstacle_mu", "mu", Obstacle, FRICTION
    doc = "a post the world model lacks: its friction coefficient (Drake combines it with the object's)"

    def null(self, world, odb, target):
        return OBSTACLE_FRICTION

    def bounds(self, world, odb, target):
        return 0.02, 2.0

    def step(self, world, odb, target):
        return 0.1


class ObstacleRadius(_Member):
    name, component, family, unit = "obstacle_radius", "radius", Obstacle, "m"
    doc = "a post the world model lacks: its radius"
    physical = PhysicalRange(0.0, 0.5, "m", "in m: a post half a metre wide is a wall of the scene, not a hidden part",
                             open_low=True)

    def null(self, world, odb, target):
        return OBSTACLE_RADIUS

    def bounds(self, world, odb, target):  # a screw's head to a box a hand's width across
        return 0.004, 0.05

    def step(self, world, odb, target):
        return 0.005


class Patch(Family):
    """A micrometre-thin sheet with its own friction coefficient over a rectangle of the surface: `half` along its
    `yaw` direction, `breadth` across it (a square, axis-aligned, unless those say otherwise). An object over it
    rests on the sheet, one straddling its edge feels both coefficients side by side."""

    name = "friction_patch"
    members = {"cx": "patch_cx", "cy": "patch_cy", "half": "patch_half", "breadth": "patch_breadth",
               "yaw": "patch_yaw", "mu": "patch_mu"}

    @classmethod
    def realise(cls, values, target, rollout, odb):
        world = rollout.world
        cx, cy, _, _ = _extent(world, odb, target)
        x, y = values.get("cx", cx), values.get("cy", cy)
        h = values.get("half", 0.05)
        b = values.get("breadth", h)
        mu = values.get("mu", odb.get(world.objects[target].type).physics.friction)
        sheet = SurfacePatch("friction_patch", (x - h, x + h, y - b, y + b), surface_top(world, odb, target), mu,
                             raised=PATCH_RAISED, yaw=values.get("yaw", 0.0))
        return rollout.with_extras(sheet)


class _PatchCentre(_Place):
    family = Patch

    def null(self, world, odb, target):
        return self._along(world, odb, target)[0]

    def step(self, world, odb, target):
        return 0.01


class PatchCx(_PatchCentre):
    name, component, axis, doc = "patch_cx", "cx", 0, "a region of other friction: its centre, world x"


class PatchCy(_PatchCentre):
    name, component, axis, doc = "patch_cy", "cy", 1, "a region of other friction: its centre, world y"


class PatchHalf(_Member):
    name, component, family, unit = "patch_half", "half", Patch, "m"
    physical = PhysicalRange(0.0, 10.0, "m", "in m: half a side of a region on a table", open_low=True)
    doc = "a region of other friction: half its length along its yaw direction (half the side of a square)"

    def null(self, world, odb, target):
        return 0.05

    def bounds(self, world, odb, target):
        _, _, hx, hy = _extent(world, odb, target)
        return 0.005, max(hx, hy)

    def step(self, world, odb, target):
        return 0.01


class PatchBreadth(PatchHalf):
    name, component = "patch_breadth", "breadth"
    doc = "a region of other friction: half its breadth across its yaw direction (a strip's length)"


class PatchYaw(_Member):
    name, component, family, unit = "patch_yaw", "yaw", Patch, "rad"
    physical = PhysicalRange(-2 * math.pi, 2 * math.pi, "rad", "in rad: an angle about the vertical")
    doc = "a region of other friction: its turn about the vertical (0: its sides along world x and y)"

    def null(self, world, odb, target):
        return 0.0

    def bounds(self, world, odb, target):
        return -2 * math.pi, 2 * math.pi  # a rectangle's turn is periodic: wide bounds so a fit never stops on one

    def step(self, world, odb, target):
        return 0.1


class PatchMu(_Member):
    name, component, family, physical = "patch_mu", "mu", Patch, FRICTION
    doc = "a region of other friction: its coefficient (like the surface's own, combined with the object's)"

    def null(self, world, odb, target):
        return odb.get(world.objects[target].type).physics.friction

    def bounds(self, world, odb, target):
        return 0.003, 3.0

    def step(self, world, odb, target):
        return 0.3 * self.null(world, odb, target)


class Support(Family):
    """Where a free object's weight rests (`bridge.sim.support`): its footprint scaled about its centroid and
    moved, as contact geometry; a new scene per value. At the null values (scale 1, no offset) nothing is added:
    the object rests on its own bottom."""

    name = "pressure_distribution"
    members = {"scale": "support_scale", "x": "support_x", "y": "support_y"}

    @classmethod
    def realise(cls, values, target, rollout, odb):
        scale, x, y = values.get("scale", 1.0), values.get("x", 0.0), values.get("y", 0.0)
        if scale == 1.0 and x == 0.0 and y == 0.0:
            return rollout
        return rollout.with_extras(SupportPressure(target, float(scale), (float(x), float(y))))


class _SupportMember(_Member):
    null_is_world = True
    family, targets = Support, "free objects"

    def null(self, world, odb, target):
        return 1.0 if self.component == "scale" else 0.0


class SupportScale(_SupportMember):
    name, component = "support_scale", "scale"
    doc = ("where an object's weight rests: its footprint's size relative to its bottom (uniform pressure over "
           "it); below 1 the weight rests towards the centre (less torsional friction), above 1 towards the rim")
    physical = PhysicalRange(0.05, 1.8, "", "a share of the object's own footprint: 0.05 is nearly a point, 1.41 a "
                             "disc's rim, 1.73 a square's corners")

    def bounds(self, world, odb, target):
        """Up to the largest spread the object's own bottom allows: all its weight at the points farthest from the
        centroid (a disc's rim: 1.41, a square's corners: 1.73; `sim.support.widest_scale`). A fit that asks for
        more wants the weight off the object: the model family is wrong (a soaking fit pressed 1.40 on a disc)."""
        from ..sim.support import widest_scale

        if target not in world.objects:
            return 0.3, 1.6
        return 0.3, min(self.physical.high, widest_scale(odb.get(world.objects[target].type)))

    def step(self, world, odb, target):
        return 0.1

    def negligible(self, world, odb, target):
        return 0.05


class _SupportOffset(_SupportMember):
    unit, axis = "m", 0
    physical = PhysicalRange(-1.0, 1.0, "m", "in m, object frame: no object on a table reaches 1 m from its centre")

    def _half(self, world, odb, target) -> float:
        return float(footprint_half(world, odb, target)[self.axis]) if target in world.objects else 0.05

    def check_on(self, value, names, rollout, odb):
        for name in names:
            h = self._half(rollout.world, odb, name)
            if abs(value) > h:
                return (f"{self.name} {value:g} m puts the centre of pressure outside {name!r} (half extent {h:.4g} m "
                        f"along its {'xy'[self.axis]})")
        return None

    def bounds(self, world, odb, target):
        h = self._half(world, odb, target)
        return -0.35 * h, 0.35 * h

    def step(self, world, odb, target):
        return 0.1 * self._half(world, odb, target)

    def negligible(self, world, odb, target):
        return 0.001


class SupportX(_SupportOffset):
    name, component, axis = "support_x", "x", 0
    doc = "where an object's weight rests: the centre of pressure's offset from the footprint's centroid, object x"


class SupportY(_SupportOffset):
    name, component, axis = "support_y", "y", 1
    doc = "where an object's weight rests: the centre of pressure's offset from the footprint's centroid, object y"


class Anisotropy(Family):
    """The object's friction on its support made direction-dependent (`bridge.sim.anisotropy`): a coefficient
    ellipse around the pair's isotropic coefficient (as the scene values have it); a new scene per value."""

    name = "anisotropic_friction"
    members = {"a_c": "aniso_c", "a_s": "aniso_s"}

    @classmethod
    def realise(cls, values, target, rollout, odb):
        a_c, a_s = values.get("a_c", 0.0), values.get("a_s", 0.0)
        world = rollout.world
        surface = support_of(world, odb, target)
        if (a_c == 0.0 and a_s == 0.0) or surface is None:
            return rollout
        mu = combined_friction(_scene_friction(rollout, odb, target), _scene_friction(rollout, odb, surface))
        return rollout.with_extras(AnisotropicFriction(target, float(a_c), float(a_s), mu,
                                                       surface_top(world, odb, surface)))


def _scene_friction(rollout, odb, name: str) -> float:
    """An object's coefficient as the rollout's scene values have it (the database's where they do not)."""
    set_ = rollout.values.objects.get(name)
    return set_.friction if set_ is not None and set_.friction is not None else \
        odb.get(rollout.world.objects[name].type).physics.friction


class _AnisotropyComponent(_Member):
    null_is_world = True
    family, targets = Anisotropy, "free objects"
    physical = PhysicalRange(-0.9, 0.9, "", "the coefficient along the grain over the isotropic one, less 1: at 1 the "
                             "coefficient across the grain would vanish")

    def null(self, world, odb, target):
        return 0.0

    def bounds(self, world, odb, target):
        return -0.6, 0.6

    def step(self, world, odb, target):
        return 0.1

    def negligible(self, world, odb, target):
        return 0.03


class AnisoC(_AnisotropyComponent):
    name, component = "aniso_c", "a_c"
    doc = ("anisotropic friction on the support: a cos 2 theta, where the coefficient is mu (1 + a) along the "
           "world direction theta and mu (1 - a) across it")


class AnisoS(_AnisotropyComponent):
    name, component = "aniso_s", "a_s"
    doc = "anisotropic friction on the support: a sin 2 theta (see aniso_c)"


class Field(Family):
    """The object's friction on its support varying over the surface (`bridge.sim.anisotropy.FrictionField`): the
    pair's coefficient (as the scene values have it) at the object's start, changing linearly by (g_x, g_y) per
    metre; a new scene per value."""

    name = "friction_field"
    members = {"g_x": "field_gx", "g_y": "field_gy"}

    @classmethod
    def realise(cls, values, target, rollout, odb):
        g_x, g_y = values.get("g_x", 0.0), values.get("g_y", 0.0)
        world = rollout.world
        surface = support_of(world, odb, target)
        if (g_x == 0.0 and g_y == 0.0) or surface is None:
            return rollout
        mu = combined_friction(_scene_friction(rollout, odb, target), _scene_friction(rollout, odb, surface))
        start = world.objects[target].pose.xyz
        return rollout.with_extras(FrictionField(target, float(g_x), float(g_y), (float(start[0]), float(start[1])),
                                                 mu, surface_top(world, odb, surface)))


class _FieldComponent(_Member):
    null_is_world = True
    family, targets, unit = Field, "free objects", "1/m"
    physical = PhysicalRange(-9.0, 9.0, "1/m", "per metre: beyond it the coefficient would halve or vanish within "
                             "the few centimetres an object is pushed")

    def null(self, world, odb, target):
        return 0.0

    def bounds(self, world, odb, target):
        return -8.0, 8.0

    def step(self, world, odb, target):
        return 1.0

    def negligible(self, world, odb, target):
        return 0.6  # 3 % over 5 cm


class FieldGx(_FieldComponent):
    name, component = "field_gx", "g_x"
    doc = "friction varying over the support: the pair coefficient's relative change per metre along world x"


class FieldGy(_FieldComponent):
    name, component = "field_gy", "g_y"
    doc = "friction varying over the support: the pair coefficient's relative change per metre along world y"


class Rate(Family):
    """The object's friction on its support depending on each footprint point's slip speed
    (`bridge.sim.anisotropy.RateFriction`, the Stribeck curve): the pair's coefficient (as the scene values have it)
    when sliding fast, (1 + drop) times it near rest, the excess decaying over `speed`; a new scene per value."""

    name = "rate_friction"
    members = {"drop": "rate_drop", "speed": "rate_speed"}

    @classmethod
    def realise(cls, values, target, rollout, odb):
        drop, speed = values.get("drop", 0.0), values.get("speed", RATE_SPEED)
        world = rollout.world
        surface = support_of(world, odb, target)
        if drop == 0.0 or surface is None:
            return rollout
        mu = combined_friction(_scene_friction(rollout, odb, target), _scene_friction(rollout, odb, surface))
        return rollout.with_extras(RateFriction(target, float(drop), float(speed), mu, surface_top(world, odb, surface)))


class RateDrop(_Member):
    null_is_world = True
    family, targets = Rate, "free objects"
    name, component = "rate_drop", "drop"
    doc = ("friction that changes with the slip speed: the coefficient near rest over the one at speed, less 1 "
           "(> 0: the Stribeck curve of dry contact, < 0: a coefficient that rises with speed)")
    physical = PhysicalRange(-0.9, 9.0, "", "the coefficient near rest stays between a tenth and ten times the one at "
                             "speed")

    def null(self, world, odb, target):
        return 0.0

    def bounds(self, world, odb, target):
        return -0.5, 3.0

    def step(self, world, odb, target):
        return 0.3

    def negligible(self, world, odb, target):
        return NEGLIGIBLE_FRICTION


class RateSpeed(_Member):
    family, targets, unit = Rate, "free objects", "m/s"
    name, component = "rate_speed", "speed"
    doc = "friction that changes with the slip speed: the speed over which the coefficient falls from rest (rate_drop)"
    physical = PhysicalRange(0.005, 1.0, "m/s", "below 5 mm/s the explicit force is unstable at a few ms a step "
                             "(bridge/sim/anisotropy.py); above 1 m/s no push of a table-top object slides")

    def null(self, world, odb, target):
        return RATE_SPEED

    def bounds(self, world, odb, target):
        return 0.01, 0.2

    def step(self, world, odb, target):
        return 0.01


class ObjectFrame(Family):
    """Where the recording's tracker puts an object's frame: the pose X_BR of the recorded frame in the object's body
    frame (markers off the centre the model's geometry assumes, a frame turned). The body starts where the recorded
    start pose and X_BR put it (X_WR0 X_BR^-1) and its poses are compared with the recording in the recorded frame
    (`Rollout.frames`); no new scene, nothing simulated differently but the start."""

    name = "object_frame"
    members = {"x": "frame_x", "y": "frame_y", "yaw": "frame_yaw"}

    @classmethod
    def realise(cls, values, target, rollout, odb):
        x, y, yaw = values.get("x", 0.0), values.get("y", 0.0), values.get("yaw", 0.0)
        if x == 0.0 and y == 0.0 and yaw == 0.0:
            return rollout
        X_BR = Pose((float(x), float(y), 0.0), (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)))
        X_WR = rollout.world.objects[target].pose  # the recording's start pose is the tracked frame's
        X_WB = Pose.from_matrix(X_WR.matrix() @ np.linalg.inv(X_BR.matrix()))
        return rollout.with_world(rollout.world.with_poses({target: X_WB})).with_frame(target, X_BR)


class _FrameMember(_Member):
    null_is_world = True
    family, targets = ObjectFrame, "free objects"

    def null(self, world, odb, target):
        return 0.0


class _FrameOffset(_FrameMember):
    unit = "m"
    physical = PhysicalRange(-1.0, 1.0, "m", "in m, object frame: no object on a table reaches 1 m from its centre")

    def _half(self, world, odb, target) -> float:
        return float(np.max(footprint_half(world, odb, target)[:2])) if target in world.objects else 0.05

    def check_on(self, value, names, rollout, odb):
        for name in names:
            h = self._half(rollout.world, odb, name)
            if abs(value) > h:
                return (f"{self.name} {value:g} m puts the recorded frame outside {name!r} (half extent {h:.4g} m): "
                        "the recording tracks another object")
        return None

    def bounds(self, world, odb, target):
        h = self._half(world, odb, target)
        return -0.5 * h, 0.5 * h

    def step(self, world, odb, target):
        return 0.002

    def negligible(self, world, odb, target):
        return 0.001


class FrameX(_FrameOffset):
    name, component = "frame_x", "x"
    doc = "the recorded frame's offset from the object's modelled frame, object x (a tracker's markers off centre)"


class FrameY(_FrameOffset):
    name, component = "frame_y", "y"
    doc = "the recorded frame's offset from the object's modelled frame, object y (a tracker's markers off centre)"


class FrameYaw(_FrameMember):
    name, component, unit = "frame_yaw", "yaw", "rad"
    doc = "the recorded frame turned about the object's vertical axis from its modelled frame"
    physical = PhysicalRange(-math.pi, math.pi, "rad", "in rad: an angle about the vertical")

    def bounds(self, world, odb, target):
        return -0.35, 0.35  # 20 deg: beyond it a symmetric outline's turn is ambiguous and the frame is another one

    def step(self, world, odb, target):
        return 0.02

    def negligible(self, world, odb, target):
        return 0.0175  # 1 deg


class ObjectScaleKind(Kind):
    """The object's size relative to its type's: its geometry scaled about the centre of its bottom (the same
    mass, the inertia scaled with it; `sim.extras.ObjectScale`); a new scene per value."""

    name, targets = "object_scale", "free objects"
    doc = ("an object's size relative to its type's model (an outline or mesh drawn at another size, another "
           "instance of the part): its whole geometry scaled about the centre of its bottom, the same mass")
    physical = PhysicalRange(0.5, 2.0, "", "a share of the modelled size: half to twice the model is another object")
    null_is_world = True

    def apply(self, value, names, rollout, odb):
        if value == 1.0:
            return rollout
        return rollout.with_extras(*(ObjectScale(n, float(value)) for n in names))

    def null(self, world, odb, target):
        return 1.0

    def bounds(self, world, odb, target):
        return 0.85, 1.15  # a model 15 % off in size is another object, not a drawing error

    def step(self, world, odb, target):
        return 0.01

    def negligible(self, world, odb, target):
        return 0.005  # half a millimetre on a 10 cm object


# --- the registry -------------------------------------------------------------------------------------------
KINDS: dict[str, Kind] = {k.name: k for k in (
    Friction(), DynamicFriction(), Dissipation(), HydroelasticModulus(),
    Mass(), MassSpread(), ComX(), ComY(), ComZ(), ForceX(), ForceY(), ForceZ(),
    Latency(), JointOffset(),
    SurfaceSlopeX(), SurfaceSlopeY(), SurfaceDz(),
    ObstacleX(), ObstacleY(), ObstacleMu(), ObstacleRadius(),
    PatchCx(), PatchCy(), PatchHalf(), PatchBreadth(), PatchYaw(), PatchMu(),
    SupportScale(), SupportX(), SupportY(),
    AnisoC(), AnisoS(), FieldGx(), FieldGy(), RateDrop(), RateSpeed(),
    SlidingFriction(), RobotFriction(),
    FrameX(), FrameY(), FrameYaw(), ObjectScaleKind(),
)}


def kind_named(name: str) -> Kind:
    try:
        return KINDS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown parameter kind {name!r}; kinds: {', '.join(KINDS)}") from None


def register_kind(kind: Kind) -> Kind:
    """Add a kind of your own to `KINDS` (call it where your code starts, before reading files that name it)."""
    if not isinstance(kind, Kind) or not getattr(kind, "name", None):
        raise ParameterError(f"register_kind needs a Kind instance with a name, got {kind!r}")
    if kind.name in KINDS and type(KINDS[kind.name]) is not type(kind):
        raise ParameterError(f"parameter kind {kind.name!r} is registered already ({type(KINDS[kind.name]).__name__})")
    KINDS[kind.name] = kind
    return kind


__all__ = ["Family", "KINDS", "Kind", "kind_named", "register_kind", "tilted_poses"]
