"""Friction that depends on the direction of sliding: a coefficient ellipse over the support, added to Drake's
isotropic Coulomb friction as a force from the object's slip velocity, computed at every step.

Why: brushed, rolled, machined or printed surfaces (the MIT pushing data's ABS sheet among them: Yu et al. 2016)
resist sliding more along one direction than across it, and no isotropic coefficient reproduces a shape's
translations and rotations at once (docs/real_push.md). Drake's contact friction is isotropic, so the
difference enters here.

The model: the object-support pair has the coefficients mu (1 + a) along the unit direction u at angle theta
and mu (1 - a) across it; with (a_c, a_s) = a (cos 2 theta, sin 2 theta) (a smooth pair of parameters, zero at
isotropy, whatever theta) the coefficient matrix is M = mu (I + a_c [[1, 0], [0, -1]] + a_s [[0, 1], [1, 0]]).
Maximum dissipation over the elliptic limit set {f : |M^-1 f| <= N} gives the friction force of a point sliding
at v: f = -N M^2 v / |M v| (along an axis: -N mu (1 +- a) v / |v|). Drake already applies -N mu v / |v|; this
module adds the difference at each of a quadrature of the footprint's points (uniform pressure, the weight m g
shared by area), regularised below the slip speed `slip_speed` (v / sqrt(|v|^2 + v_s^2)) so that an object at
rest feels none of it. The sum is one spatial force on the body, applied while its bottom is within `reach`
of the support's top.

Neglected: the static part (a sticking object feels Drake's isotropic static friction), the pressure's shift as
the object accelerates or tips (the weight stays shared uniformly), the surface's tilt (the ellipse lies in the
world x-y plane), other objects on the same surface. The force is explicit (computed from the state at the start
of a step): stable while a N / (m v_s) x dt stays well below 2, i.e. v_s >= a g dt, 4 mm/s at a = 1, dt = 4 ms.

Drake facts: a system that reads the plant's state output and feeds its applied-force input makes no algebraic
loop in a discrete plant (the state output does not depend on the inputs of the same step); the plant has one
applied spatial force input, so several force sources meet in an `ExternallyAppliedSpatialForceMultiplexer`.
The system's own plant context holds the default parameters: the load is the object database's mass (a fitted
`mass` does not change it).

The same force carries a friction *field* (`FrictionField`): a pair coefficient that changes over the surface,
mu (1 + g . (p - p0)) at a footprint point's world position p, p0 where the object started (a worn, waxed or
dusty region whose edge the object crosses; the square patch of `sim/extras.SurfacePatch` is a sharp special
case). Each point adds (factor - 1) times Drake's isotropic force; neglected as above, and the field is the
first-order term only (a sharp edge is smoothed into a slope).

And friction that changes with the slip speed (`RateFriction`, the Stribeck curve of dry and boundary-lubricated
contacts): mu (1 + drop exp(-v / speed)) at a footprint point sliding at v, Drake's kinetic mu at speed and
mu (1 + drop) near rest. Where an object turns about a point under it, the points near that point slide slowly
and the rim fast, so the curve reshapes its torsional friction against its sliding friction, which no single
coefficient does; a push through the centre feels it only as a coefficient. Neglected as above, and the stiction
itself: below `SLIP_SPEED` the added force fades like every force of this module (a resting object holds by
Drake's static friction). The explicit force is stable while g mu drop dt / speed stays well below 2 (the slope of
the curve is a negative damping): speed >= 10 mm/s at drop 3, mu 0.5, dt 3 ms.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem

from ..errors import SceneError
from ..values import GRAVITY

SLIP_SPEED = 0.005  # m/s: below this the added force fades (regularisation; see the stability note above)
REACH = 0.001  # m: the object's bottom within this of the support's top is resting on it
MAX_ANISOTROPY = 0.9  # |a| < 1: a coefficient across the grain must stay positive
MIN_FIELD = 0.1  # the field's coefficient never falls below this share of the pair's (it stays positive)


class SlipExtra:
    """What the slip-force extras share: a free object `object` sliding with the pair coefficient `mu` on a
    support whose top is at `top_z` (world), and a force that `SlipFriction` adds from the slip velocity (the
    system is added with the diagram's sources, `scene._build`, so `add_to` only checks)."""

    label: ClassVar[str]
    object: str
    mu: float
    top_z: float

    def invalid(self) -> str | None:
        """What is wrong with the extra's own values, or None."""
        return None

    def check(self, world, odb) -> None:
        if self.object not in world.objects or odb.get(world.objects[self.object].type).fixed:
            raise SceneError(f"{self.label}: no free object {self.object!r} in world {world.name!r}")
        problem = self.invalid()
        if problem:
            raise SceneError(f"{self.label} on {self.object!r}: {problem}")

    def add_to(self, plant, world, odb, config) -> None:
        self.check(world, odb)

    def matrix(self) -> np.ndarray:
        """The pair's coefficient matrix (2, 2, world x-y) before the per-point factor."""
        return self.mu * np.eye(2)

    def factor(self, xy: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """The coefficient over `matrix()` at world points `xy` (n, 2) sliding at `speed` (n,) m/s."""
        return np.ones(len(xy))


@dataclass(frozen=True)
class AnisotropicFriction(SlipExtra):
    """Object `object`'s pair coefficient `mu` made anisotropic by (`a_c`, `a_s`) (module docstring)."""

    label: ClassVar[str] = "anisotropic friction"
    object: str
    a_c: float
    a_s: float
    mu: float
    top_z: float

    @property
    def anisotropy(self) -> float:
        return math.hypot(self.a_c, self.a_s)

    @property
    def angle(self) -> float:
        """The direction (rad, world, in (-pi/2, pi/2]) of the larger coefficient."""
        return 0.5 * math.atan2(self.a_s, self.a_c)

    def invalid(self) -> str | None:
        if not (self.anisotropy < MAX_ANISOTROPY and self.mu > 0 and math.isfinite(self.top_z)):
            return (f"needs |a| < {MAX_ANISOTROPY} (got {self.anisotropy:.3g}) and a positive coefficient "
                    f"(got {self.mu!r})")
        return None

    def matrix(self) -> np.ndarray:
        return self.mu * np.array([[1 + self.a_c, self.a_s], [self.a_s, 1 - self.a_c]])


@dataclass(frozen=True)
class FrictionField(SlipExtra):
    """Object `object`'s pair coefficient `mu` varying over the surface as mu (1 + g . (p - origin)),
    g = (`g_x`, `g_y`) per metre, p world (x, y) (module docstring)."""

    label: ClassVar[str] = "friction field"
    object: str
    g_x: float
    g_y: float
    origin: tuple[float, float]  # m, world: where the coefficient is `mu` (the object's start)
    mu: float
    top_z: float

    def invalid(self) -> str | None:
        if not (self.mu > 0 and all(map(math.isfinite, (self.g_x, self.g_y, *self.origin, self.top_z)))):
            return (f"needs finite values and a positive coefficient (got mu {self.mu!r}, g ({self.g_x!r}, "
                    f"{self.g_y!r}))")
        return None

    def factor(self, xy: np.ndarray, speed: np.ndarray) -> np.ndarray:
        return np.maximum(MIN_FIELD, 1.0 + (np.asarray(xy) - np.asarray(self.origin)) @ np.array([self.g_x, self.g_y]))


@dataclass(frozen=True)
class RateFriction(SlipExtra):
    """Object `object`'s pair coefficient `mu` rising to mu (1 + `drop`) as a footprint point's slip speed
    falls well below `speed` (m/s; module docstring)."""

    label: ClassVar[str] = "rate-dependent friction"
    object: str
    drop: float
    speed: float
    mu: float
    top_z: float

    def invalid(self) -> str | None:
        if not (self.drop > MIN_FIELD - 1 and self.speed > 0 and self.mu > 0
                and all(map(math.isfinite, (self.drop, self.speed, self.top_z)))):
            return (f"needs drop > {MIN_FIELD - 1:g}, a positive speed and coefficient (got drop {self.drop!r}, "
                    f"speed {self.speed!r}, mu {self.mu!r})")
        return None

    def factor(self, xy: np.ndarray, speed: np.ndarray) -> np.ndarray:
        return 1.0 + self.drop * np.exp(-np.asarray(speed) / self.speed)


def footprint_points(polygon: np.ndarray, levels: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 2), weights summing to 1): a quadrature of a uniform polygon, the centroids of its fan
    triangles (from the area centroid) each split `levels` times into four."""
    from .prisms import centroid

    c = centroid(polygon)
    tris = np.array([[c, polygon[i], polygon[(i + 1) % len(polygon)]] for i in range(len(polygon))])
    for _ in range(levels):
        a, b, d = tris[:, 0], tris[:, 1], tris[:, 2]
        ab, bd, da = (a + b) / 2, (b + d) / 2, (d + a) / 2
        tris = np.concatenate([np.stack(t, axis=1) for t in ((a, ab, da), (ab, b, bd), (da, bd, d), (ab, bd, da))])
    area = 0.5 * np.abs((tris[:, 1, 0] - tris[:, 0, 0]) * (tris[:, 2, 1] - tris[:, 0, 1])
                        - (tris[:, 2, 0] - tris[:, 0, 0]) * (tris[:, 1, 1] - tris[:, 0, 1]))
    return tris.mean(axis=1), area / area.sum()


def slip_force(M: np.ndarray, mu: float, load: np.ndarray, velocity: np.ndarray,
               slip_speed: float = SLIP_SPEED, factor: np.ndarray | None = None) -> np.ndarray:
    """The force (n, 2) to add at points sliding at `velocity` (n, 2) under `load` (n,) normal force each:
    the elliptic friction -N M^2 v / |M v| (times `factor` per point, a field's) less Drake's isotropic
    -N mu v / |v|, both regularised."""
    Mv = velocity @ M  # M is symmetric
    elliptic = (Mv @ M) / np.sqrt(np.sum(Mv ** 2, axis=1) + (mu * slip_speed) ** 2)[:, None]
    if factor is not None:
        elliptic = elliptic * np.asarray(factor)[:, None]
    isotropic = mu * velocity / np.sqrt(np.sum(velocity ** 2, axis=1) + slip_speed ** 2)[:, None]
    return -load[:, None] * (elliptic - isotropic)


class SlipFriction(LeafSystem):
    """Outputs the anisotropic friction's, the friction fields' and the rate-dependent friction's added spatial
    force on each object that has one, from the plant's state (positions and velocities) at the step's start."""

    def __init__(self, plant, entries: list[tuple[SlipExtra, object, np.ndarray, np.ndarray, float]]):
        """`entries`: (the extra, its body, footprint points (n, 2) body frame, weights, the bottom's z in the
        body frame)."""
        super().__init__()
        self._plant = plant
        self._entries = []
        for extra, body, points, weights, z0 in entries:
            M = extra.matrix()
            p_B = np.column_stack([points, np.full(len(points), z0)])
            self._entries.append((extra, body, p_B, weights, M))
        self._state = self.DeclareVectorInputPort("plant_state", plant.num_multibody_states()).get_index()
        self.DeclareAbstractOutputPort("forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]),
                                       self._calc)
        self._plant_context = plant.CreateDefaultContext()

    def _calc(self, context, output) -> None:
        plant, pc = self._plant, self._plant_context
        plant.SetPositionsAndVelocities(pc, self.get_input_port(self._state).Eval(context))
        forces = []
        for extra, body, p_B, weights, M in self._entries:
            X = plant.EvalBodyPoseInWorld(pc, body)
            R, p = X.rotation().matrix(), X.translation()
            r = p_B @ R.T  # points relative to the body origin, world frame
            if float(np.min(r[:, 2])) + p[2] > extra.top_z + REACH:
                continue  # lifted or tipped off its support: no sliding on it
            V = plant.EvalBodySpatialVelocityInWorld(pc, body)
            w, v = V.rotational(), V.translational()
            v_points = v[None, :] + np.cross(w[None, :], r)
            load = body.get_mass(pc) * GRAVITY * weights
            slip = v_points[:, :2]
            f2 = slip_force(M, extra.mu, load, slip, factor=extra.factor(p[None, :2] + r[:, :2],
                                                                          np.linalg.norm(slip, axis=1)))
            f = np.column_stack([f2, np.zeros(len(f2))])
            applied = ExternallyAppliedSpatialForce()
            applied.body_index = body.index()
            applied.p_BoBq_B = np.zeros(3)
            applied.F_Bq_W = SpatialForce(np.cross(r, f).sum(axis=0), f.sum(axis=0))
            forces.append(applied)
        output.set_value(forces)
