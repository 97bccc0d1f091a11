"""The catalog of effects a diagnosis can name: one file each, one explicit registry.

An effect is a named bundle of parameter kinds (`bridge.params.kinds`) with its signature, seeds and,
optionally, how the proof conceals it. To add an effect, write one `Effect` subclass (see base.py) and register
it where your code starts::

    from bridge.diagnosis.effects import register_effect
    register_effect(MyEffect())
"""
from __future__ import annotations

from ...errors import DiagnosisError
from ...params import KINDS
from .anisotropic_friction import AnisotropicFrictionEffect
from .base import Effect, Evidence, Recovery, Truth, pname
from .com_offset import ComOffset
from .friction import Friction
from .friction_field import FrictionFieldEffect
from .friction_patch import FrictionPatch
from .hidden_obstacle import HiddenObstacle
from .latency import Latency
from .mass import Mass
from .none import NoEffect
from .object_frame import ObjectFrameEffect
from .object_scale import ObjectScaleEffect
from .pressure_distribution import PressureDistribution
from .pusher_offset import PusherOffset
from .surface_tilt import SurfaceTilt

EFFECTS: dict[str, Effect] = {
    "none": NoEffect(),
    "friction": Friction(),
    "mass": Mass(),
    "com_offset": ComOffset(),
    "surface_tilt": SurfaceTilt(),
    "friction_patch": FrictionPatch(),
    "latency": Latency(),
    "pusher_offset": PusherOffset(),
    "hidden_obstacle": HiddenObstacle(),
    "pressure_distribution": PressureDistribution(),
    "anisotropic_friction": AnisotropicFrictionEffect(),
    "friction_field": FrictionFieldEffect(),
    "object_frame": ObjectFrameEffect(),
    "object_scale": ObjectScaleEffect(),
}

__all__ = ["EFFECTS", "Effect", "Evidence", "Recovery", "Truth", "get_effect", "pname", "register_effect"]


def get_effect(name: str) -> Effect:
    try:
        return EFFECTS[name]
    except (KeyError, TypeError):
        raise DiagnosisError(f"unknown effect {name!r}; effects: {', '.join(EFFECTS)}") from None


def register_effect(effect: Effect) -> Effect:
    """Add (or replace) an effect in the catalog under its `name`."""
    if not isinstance(effect, Effect) or not effect.name:
        raise DiagnosisError(f"register_effect needs an Effect instance with a name, got {effect!r}")
    unknown = [k for k in (*effect.kinds, *effect.fixed) if k not in KINDS]
    if unknown:
        raise DiagnosisError(f"effect {effect.name!r} names the unknown parameter kind {unknown[0]!r}")
    EFFECTS[effect.name] = effect
    return effect
