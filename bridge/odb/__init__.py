"""The object database: object types, their geometry and physics, and the SIEs that decide their predicates."""
from .database import ObjectDatabase, load_object_database, parse_dataset_options
from .types import Geometry, Gripper, ObjectType, Physics, PredicateDecl, RobotSpec, SIERef

__all__ = [
    "Geometry", "Gripper", "ObjectDatabase", "ObjectType", "Physics", "PredicateDecl",
    "RobotSpec", "SIERef", "load_object_database", "parse_dataset_options",
]
