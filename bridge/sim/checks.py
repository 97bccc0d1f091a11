"""Each concrete type of an object database built alone in Drake (`bridge check`): what a scene with an object of
the type would meet (its mass properties, a mesh Drake cannot read or make hydroelastic, a robot model Drake cannot
load), found before any recording is replayed and named by the type's file and field."""
from __future__ import annotations

from ..errors import ObjectDatabaseError, SceneError
from ..odb import ObjectDatabase
from ..values import Pose
from ..world import ObjectState, RobotState, WorldState
from .scene import SimConfig, _build
from .shapes import mass_properties


def check_type(odb: ObjectDatabase, type_name: str, config: SimConfig = SimConfig()) -> bool:
    """Build a scene holding one object of `type_name` (or, for a robot type, the robot at its home position) and
    make a context of it. False when the type cannot be checked here (a mesh of a dataset that is not found)."""
    t = odb.get(type_name)
    if t.is_robot:
        spec = t.robot
        world = WorldState({}, robot=RobotState("robot", type_name, Pose(), tuple(spec.home_positions().items())),
                           name=type_name)
        field = f"{type_name}.robot.model"
    else:
        if t.geometry is None or t.geometry.unresolved is not None:
            return False
        if not t.fixed:
            mass_properties(odb, type_name)
        world = WorldState({type_name: ObjectState(type_name, type_name, Pose((0.0, 0.0, 1.0)))}, name=type_name)
        field = type_name
    try:
        _build(world, odb, config, (), None).new_context()
    except SceneError as exc:
        if exc.field == field:  # it names this entry already (a robot model Drake cannot load)
            raise ObjectDatabaseError(exc.message, source=str(t.source), field=field) from None
        raise ObjectDatabaseError(f"Drake cannot build an object of this type: {str(exc).splitlines()[0]}",
                                  source=str(t.source), field=field) from None
    except (RuntimeError, ValueError) as exc:
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ObjectDatabaseError(f"Drake cannot build an object of this type: {message}", source=str(t.source),
                                  field=field) from None
    return True
