"""One family of errors, so the command line can turn any of them into one clear line.

Every message names where the problem is (file, field, object) and, where it helps, the valid choices.
"""
from __future__ import annotations


class BridgeError(Exception):
    """Base of every error bridge raises on purpose (bad input, failed simulation, ...)."""

    def __init__(self, message: str, *, source: str | None = None, field: str | None = None):
        self.source = source
        self.field = field
        self.message = message  # without the source and field
        where = ": ".join(part for part in (source, field) if part)
        super().__init__(f"{where}: {message}" if where else message)


class ObjectDatabaseError(BridgeError):
    """A malformed object type, SIE reference, robot entry or mesh in the object database."""


class WorldStateError(BridgeError):
    """A world-state file that does not fit the object database."""


class PddlError(BridgeError):
    """Malformed or inconsistent PDDL: action templates, domains, problems, plans."""


class ActionError(PddlError):
    """A ground action that cannot be applied (unknown action, wrong arguments, unmet precondition)."""


class SIEError(BridgeError):
    """An SIE that raised or returned malformed facts."""


class RecordingError(BridgeError):
    """Bad telemetry, observed poses or recording folder."""


class SceneError(BridgeError):
    """A scene that cannot be built in Drake, or a simulation that failed."""


class SimulationFailure(SceneError):
    """The simulation produced garbage (NaN, object through the table, robot not following telemetry)."""


class LimitSurfaceError(BridgeError):
    """Bad input to the limit-surface baseline of planar pushing: an outline, a pusher path, a coefficient."""


class ParameterError(BridgeError):
    """A malformed parameter or scene file, an unknown kind, a target that names nothing."""


class FitError(BridgeError):
    """A fit that cannot run (no trials, no free parameter, a checkpoint of another fit, ...)."""


class DiagnosisError(BridgeError):
    """A diagnosis that cannot run (no observations, unknown effect, ...)."""
