"""The diagram's two sources that a replay sets: the robot's desired state (its telemetry) and constant external
forces on free bodies.

The forces live in the replay's context (a numeric parameter), so nothing of one replay stays behind in the
diagram. The desired state lives in the diagram: Drake's `TrajectorySource` keeps its trajectory in the system
(`UpdateTrajectory`), and each replay sets it at its start (`set_desired`). A Python LeafSystem reading the
trajectory from an abstract parameter of the context (what bridge had before) costs 20 us per evaluation, once
per step: 5 % of a replay's CPU (8 % of Drake's `AdvanceTo` on real ellip3 pushes, measured); the C++ source
costs nothing measurable. The price: two replays of one scene cannot run side by side, so scenes are cached per
thread (`rollout.scene_for`) and a replay runs to its end before the next starts.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import BasicVector, LeafSystem
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial


def desired_state_source(n: int) -> TrajectorySource:
    """The robot's desired [q; v] for its `n` actuated joints: a first-order hold through joint samples and its
    derivative (what the PD controllers track), set per replay with `set_desired`."""
    return TrajectorySource(_hold(np.array([0.0, 1.0]), np.zeros((2, n))), output_derivative_order=1)


def set_desired(source: TrajectorySource, context, times: np.ndarray, positions: np.ndarray) -> None:
    """Track `positions` (rows: samples, columns: actuators in desired-state order) at `times`; the first sample
    is held from one second before t = 0 (or before the first sample), the last for 1000 s after, so the desired
    velocity is zero outside the samples (Drake's PiecewisePolynomial holds its end values outside its span).
    `context` (the replay's) forgets any desired state it computed before."""
    source.UpdateTrajectory(_hold(times, positions))
    context.SetTime(context.get_time())  # Drake fact: a trajectory changed in the system leaves caches stale


def _hold(times: np.ndarray, positions: np.ndarray) -> PiecewisePolynomial:
    times = np.asarray(times, dtype=float)
    positions = np.asarray(positions, dtype=float)
    padded_times = np.concatenate([[min(0.0, times[0]) - 1.0], times, [times[-1] + 1e3]])
    padded = np.vstack([positions[:1], positions, positions[-1:]])
    return PiecewisePolynomial.FirstOrderHold(padded_times, padded.T)


class ConstantForces(LeafSystem):
    """Outputs one force per body (world frame, at a point of the body: by default its centre of mass in the
    object database), read from a parameter."""

    def __init__(self, bodies: Sequence[tuple[str, object]]):
        super().__init__()
        self._names = [n for n, _ in bodies]
        self._bodies = [b for _, b in bodies]
        self._param = self.DeclareNumericParameter(BasicVector(np.zeros(6 * len(bodies))))
        # depends on the parameter alone: computed once per change, not at every step
        self.DeclareAbstractOutputPort(
            "forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]), self._calc,
            prerequisites_of_calc={self.pn_ticket()})

    def set_forces(self, context, forces: Mapping[str, Sequence[float]],
                   points: Mapping[str, Sequence[float]] | None = None) -> None:
        """`forces[name]` (N, world frame) at `points[name]` (m, body frame; default: the database's centre of
        mass)."""
        values = np.zeros(6 * len(self._names))
        for i, name in enumerate(self._names):
            if name in forces:
                point = (points or {}).get(name, self._bodies[i].default_com())
                values[6 * i: 6 * i + 6] = (*forces[name], *point)
        context.get_mutable_numeric_parameter(self._param).SetFromVector(values)

    def forces(self, context) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """The forces and points written in `context` (what `set_forces` takes)."""
        values = context.get_numeric_parameter(self._param).get_value().reshape(-1, 6)
        written = [i for i, row in enumerate(values) if row[:3].any()]
        return ({self._names[i]: values[i, :3].copy() for i in written},
                {self._names[i]: values[i, 3:].copy() for i in written})

    def _calc(self, context, output) -> None:
        values = context.get_numeric_parameter(self._param).get_value()
        if not values.any():  # the usual case, evaluated every step: no Python loop
            output.set_value([])
            return
        forces = []
        for i, body in enumerate(self._bodies):
            f = values[6 * i: 6 * i + 3]
            if np.any(f):
                applied = ExternallyAppliedSpatialForce()
                applied.body_index = body.index()
                applied.p_BoBq_B = values[6 * i + 3: 6 * i + 6]
                applied.F_Bq_W = SpatialForce(np.zeros(3), f)
                forces.append(applied)
        output.set_value(forces)
