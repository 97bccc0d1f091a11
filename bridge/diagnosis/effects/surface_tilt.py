"""`surface_tilt`: the support surface is not level (or not at the height the world model says).

Modelled as a tilted surface: the fixture (and every free object standing on it) is rotated about the point of
its top above its centre so that it slopes downhill along (slope_x, slope_y) (rad; angle about
hypot(slope_x, slope_y), downhill direction atan2(slope_y, slope_x)) and raised by `dz`. The objects keep their
x, y; they stand on the tilted top, tilted with it. A new scene per value (the fixture's pose is structure);
building one takes a few tens of milliseconds.

The same slope as a constant force m g sin(slope) on each object (the tangential part of gravity, without the
tilt a pose sensor would see) is available to `bridge fit` as the parameter kinds `surface_slope_x` /
`surface_slope_y` (target: the surface), registered here.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from ...sim.shapes import mass_properties
from ...values import Pose
from .base import Contribution, Effect, Evidence, ParamSpec, movable_objects, support_of, supported_by, surface_top

G = 9.81


def tilted_poses(world, odb, surface: str, slope_x: float, slope_y: float, dz: float = 0.0) -> dict[str, Pose]:
    """New poses of the surface and the free objects on it: tilted about the top above its centre, raised by dz."""
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


def tilt_forces(world, odb, surface: str, slope_x: float, slope_y: float) -> dict[str, tuple[float, float, float]]:
    """The downhill force on each free object standing on `surface`."""
    forces = {}
    if slope_x == 0.0 and slope_y == 0.0:
        return forces
    for name in supported_by(world, odb, surface):
        m = mass_properties(odb, world.objects[name].type).mass
        forces[name] = (m * G * math.sin(slope_x), m * G * math.sin(slope_y), 0.0)
    return forces


class SurfaceTilt(Effect):
    name = "surface_tilt"
    summary = "the support surface is tilted"
    mechanism = "world poses: the fixture and what stands on it tilted (and raised by dz); a new scene per value"
    signature_text = ("drift in one world direction in every recording, whatever the push direction, from the "
                      "first contact on; observed tilt of resting objects when tilt is measured")

    def targets(self, world, odb, observed):
        surfaces = [support_of(world, odb, n) for n in observed if n in movable_objects(world, odb)]
        return tuple(dict.fromkeys(s for s in surfaces if s))

    def params(self, world, odb, target):
        return (ParamSpec("slope_x", -0.15, 0.15, 0.0, 0.01, "rad", "downhill component along world x",
                          negligible=0.0017),
                ParamSpec("slope_y", -0.15, 0.15, 0.0, 0.01, "rad", "downhill component along world y",
                          negligible=0.0017),
                ParamSpec("dz", -0.01, 0.01, 0.0, 0.001, "m", "height change of the top above the centre"))

    def contribute(self, world, odb, target, values):
        poses = tilted_poses(world, odb, target, values["slope_x"], values["slope_y"], values.get("dz", 0.0))
        return Contribution(poses=tuple(poses.items()))

    def describe(self, world, odb, target, values):
        return {"tilt_deg": math.degrees(math.hypot(values["slope_x"], values["slope_y"])),
                "downhill_deg": math.degrees(math.atan2(values["slope_y"], values["slope_x"]))}

    def signature(self, evidence: Evidence, target: str) -> float:
        dirs = [np.asarray(f["world_dir"]) for f in evidence.significant() if f.get("world_dir") is not None]
        consistency = float(np.linalg.norm(np.mean(dirs, axis=0))) if len(dirs) >= 2 else 0.3
        early = 1.0 - min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        tilt = min(1.0, 2.0 * evidence.mean("tilt"))
        return min(1.0, 0.15 + 0.5 * consistency * early + 0.35 * tilt)


# --- the same force as parameter kinds for bridge fit -------------------------------------------------------------
def _register_kinds() -> None:
    from dataclasses import replace as _replace

    from ...fit.params import PARAMETER_KINDS, ParameterKind, register_kind

    class _Slope(ParameterKind):
        axis = 0
        unit, targets = "rad", "objects"

        def apply(self, value, names, setting):
            forces = dict(setting.params.external_forces)
            for surface in names:
                slopes = [0.0, 0.0]
                slopes[self.axis] = float(value)
                for obj, f in tilt_forces(setting.world, setting.odb, surface, *slopes).items():
                    old = forces.get(obj, (0.0, 0.0, 0.0))
                    forces[obj] = tuple(a + b for a, b in zip(old, f))
            return _replace(setting, params=_replace(setting.params, external_forces=forces))

    if "surface_slope_x" not in PARAMETER_KINDS:
        register_kind(type("SurfaceSlopeX", (_Slope,), {"name": "surface_slope_x", "axis": 0,
                                                        "doc": "surface tilt: downhill slope along world x (rad)"}))
    if "surface_slope_y" not in PARAMETER_KINDS:
        register_kind(type("SurfaceSlopeY", (_Slope,), {"name": "surface_slope_y", "axis": 1,
                                                        "doc": "surface tilt: downhill slope along world y (rad)"}))


_register_kinds()
