"""bridge: keep a robot's symbolic world state true while a person teleoperates it.

Data flows one way: recording (telemetry) -> simulation (Drake) -> inference (SIEs) -> world state -> PDDL.
The main entry points are re-exported here; each lives in the module named after what it holds.
"""
from .errors import BridgeError
from .odb import ObjectDatabase, load_object_database
from .inference import SIE, EvaluationContext, infer_state
from .values import Contact, Fact, Pose
from .world import WorldState, load_world_state, save_world_state

__all__ = [
    "SIE", "BridgeError", "Contact", "EvaluationContext", "Fact", "ObjectDatabase", "Pose", "WorldState",
    "infer_state", "load_object_database", "load_world_state", "save_world_state",
]
__version__ = "0.1.0"
