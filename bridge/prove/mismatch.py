"""Worlds that differ from the diagnosis' model in ways no effect of the catalog names: the mismatched-world proof.

A proof whose recordings come from the very model the diagnosis fits measures only whether the method recognises
its own model. Real recordings, and recordings made by someone else's simulator, differ from the model
everywhere a little: how stiff and how lossy the contact is, the integrator's step, how the servo follows its
command, what the contact geometry of a mesh really is, the density, the friction of the actual materials, how
the sensors err. A `Mismatch` is one such set of differences, drawn per case (`draw_mismatch`) and applied to
every true replay of the case (`Mismatch.apply`), beneath the concealed effect; the diagnosis gets the object
database's model as always.

| difference              | drawn                                                   | the model has          |
|-------------------------|---------------------------------------------------------|------------------------|
| time step               | 1, 2 or 4 ms; halved where the step rocks the object    | 2 ms                   |
|                         | (`generate.recordable_step`)                            |                        |
| mesh contact            | the outline or its convex hull, on an even footprint   | the outline            |
| contact stiffness       | hydroelastic modulus x 0.3 .. 3 (log-uniform)           | the database's         |
| contact dissipation     | 0.3 .. 5 s/m                                            | the database's (1)     |
| density                 | x 0.92 .. 1.08                                          | the database's         |
| base frictions          | surface pair x 1.3 .. 2 or / 1.3 .. 2; object x 0.7 .. 1.4 | the database's      |
| pusher servo            | PD gains x 0.1 .. 3 (damping ratio kept); the recorded | the model's gains      |
|                         | telemetry is what the encoders read                    |                        |
| motion capture          | white noise 0.05 .. 0.4 mm, 0.5 .. 3 mrad; a slow drift  | -                      |
|                         | (AR(1), 0.1 s) up to 0.3 mm; rare clock steps back     |                        |
| force sensor            | noise 0.02 .. 0.2 N, gain x 0.93 .. 1.07                | -                      |
| rod start               | 0.5 .. 3 mm from the object (the matched proof: 4 mm); | -                      |
|                         | from its hull where the world's contact is the hull     |                        |

A case whose concealed effect is `friction` keeps the database's coefficients under it (the effect sets the
surface's), so that its truth stays the effect's own.

Left out on purpose: point contact and Drake's other discrete approximations (sap, similar). Measured on rect1
pushes (4 pushes, final poses against the model's): point contact 2-12 mm and 13 deg, sap / similar 1-7 mm and
up to 10 deg, where every listed difference moves a push by at most 4 mm / 10 deg (a 4 ms step; most by under
1 mm / 1 deg). A resting object's weight on a few points is a pressure distribution (the catalog's
`pressure_distribution`), not a difference the catalog does not name, and the convex approximations' sliding
is a solver's, not a world's. So is Drake's own hull of a mesh resting on its fan of tetrahedra (`mesh_contact:
"drake"`; drawn until session 47): its torsional friction hinges on where the sheet's triangles cut the few
bottom tetrahedra (tri1 spun at four places turned 0.14 to 2.5 times as far as on an even footprint); the hull
is kept as geometry (`mesh_contact: "hull"`: what the rod meets), carried evenly.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from ..odb import ObjectDatabase
from ..rollout.rollout import Rollout
from ..sim.extras import RobotGains
from ..sim.friction import combined_friction, surface_friction_for
from ..sim.shapes import mass_properties

TIME_STEPS = (0.001, 0.002, 0.004)  # s


@dataclass(frozen=True)
class Sensors:
    """How the recorder errs: motion-capture noise (white, plus a slow AR(1) drift of time constant `drift_tau`),
    the force sensor's noise and gain, and the share of object-pose timestamps that step back (clock jitter)."""

    position: float = 3e-4  # m, 1 sigma per axis
    rotation: float = 2e-3  # rad, 1 sigma per axis
    drift: float = 0.0  # m, stationary 1 sigma of the drift per axis
    drift_tau: float = 0.1  # s
    force: float = 0.05  # N, 1 sigma per axis
    force_gain: float = 1.0
    jitter: float = 0.0  # share of pose timestamps stepped back by 0.2 .. 1.5 ms

    def pose_noise(self, times: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """(n, 3) position noise (m) and (n, 3) rotation-vector noise (rad) at `times`."""
        n = len(times)
        position = rng.normal(0.0, self.position, (n, 3))
        if self.drift > 0 and n > 1:
            dt = float(np.median(np.diff(times)))
            a = math.exp(-dt / self.drift_tau)
            shocks = rng.normal(0.0, self.drift * math.sqrt(1 - a * a), (n, 3))
            drift = np.zeros((n, 3))
            drift[0] = rng.normal(0.0, self.drift, 3)
            for k in range(1, n):
                drift[k] = a * drift[k - 1] + shocks[k]
            drift[:, 2] = 0.0  # a planar motion-capture drift
            position = position + drift
        return position, rng.normal(0.0, self.rotation, (n, 3))


@dataclass(frozen=True)
class Mismatch:
    """One world's differences from the model (see the module's table). `Mismatch()` is the matched world."""

    time_step: float = 0.002
    mesh_contact: str = "prism"
    modulus_scale: float = 1.0
    dissipation: float | None = None
    density_scale: float = 1.0
    surface_friction: float | None = None
    object_friction: float | None = None
    gain_scale: float = 1.0
    sensors: Sensors = field(default_factory=Sensors)
    gap: tuple[float, float] = (0.004, 0.004)  # m between rod and object at the start (drawn per push)

    def apply(self, rollout: Rollout, obj: str, surface: str, odb: ObjectDatabase) -> Rollout:
        """The true rollout of a world with these differences: simulator settings, the object's and surface's
        values, the robot's servo."""
        config = replace(rollout.config, time_step=self.time_step, mesh_contact=self.mesh_contact)
        physics = odb.get(rollout.world.objects[obj].type).physics
        changes: dict[str, Any] = {}
        if self.modulus_scale != 1.0 and physics.hydroelastic_modulus is not None:
            changes["hydroelastic_modulus"] = physics.hydroelastic_modulus * self.modulus_scale
        if self.dissipation is not None:
            changes["dissipation"] = self.dissipation
        if self.density_scale != 1.0:
            changes["mass"] = mass_properties(odb, rollout.world.objects[obj].type).mass * self.density_scale
        if self.object_friction is not None:
            changes["friction"] = self.object_friction
        values = rollout.values.with_object(obj, **changes) if changes else rollout.values
        if self.surface_friction is not None:
            values = values.with_object(surface, friction=self.surface_friction)
        out = replace(rollout, config=config, values=values)
        if self.gain_scale != 1.0:
            out = out.with_extras(RobotGains(self.gain_scale, math.sqrt(self.gain_scale)))
        return out

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def draw_mismatch(rng: np.random.Generator, odb: ObjectDatabase, object_type: str, surface_type: str, *,
                  frictions: bool = True) -> Mismatch:
    """A world's differences from the model, drawn from the ranges of the module's table. `frictions` False keeps
    the database's coefficients (a case whose concealed effect is `friction` sets them itself)."""
    mu_surface = odb.get(surface_type).physics.friction
    mu_object = odb.get(object_type).physics.friction
    factor = rng.uniform(1.3, 2.0) ** (1 if rng.random() < 0.5 else -1)
    object_factor = rng.uniform(0.7, 1.4)
    sensors = Sensors(position=rng.uniform(5e-5, 4e-4), rotation=rng.uniform(5e-4, 3e-3),
                      drift=rng.uniform(0.0, 3e-4), force=rng.uniform(0.02, 0.2), force_gain=rng.uniform(0.93, 1.07),
                      jitter=0.01 if rng.random() < 0.3 else 0.0)
    return Mismatch(
        time_step=float(rng.choice(TIME_STEPS)),
        mesh_contact="hull" if rng.random() < 0.5 else "prism",
        modulus_scale=float(math.exp(rng.uniform(math.log(0.3), math.log(3.0)))),
        dissipation=float(rng.uniform(0.3, 5.0)),
        density_scale=float(rng.uniform(0.92, 1.08)),
        surface_friction=float(surface_friction_for(factor * combined_friction(mu_object, mu_surface),
                                                    mu_object * object_factor)) if frictions else None,
        object_friction=float(mu_object * object_factor) if frictions else None,
        gain_scale=float(math.exp(rng.uniform(math.log(0.1), math.log(3.0)))),
        sensors=sensors,
        gap=(0.0005, 0.003))
