"""The diagram's two sources whose values live in the context, not in the diagram: the robot's desired state
(its telemetry) and constant external forces on free bodies. A replay writes them into its own context, so one
built diagram serves any number of replays, one after another or side by side, and nothing of one replay stays
behind in the diagram.

Drake fact: `TrajectorySource` keeps its trajectory in the system itself (`UpdateTrajectory` changes the
diagram), which is why the desired state is a small LeafSystem reading an abstract parameter instead.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import BasicVector, LeafSystem
from pydrake.trajectories import PiecewisePolynomial


class _Hold:
    """A first-order hold through joint samples and its derivative (what the PD controllers track)."""

    def __init__(self, times: np.ndarray, positions: np.ndarray):
        self.q = PiecewisePolynomial.FirstOrderHold(np.asarray(times, dtype=float),
                                                    np.asarray(positions, dtype=float).T)
        self.v = self.q.MakeDerivative(1)


class DesiredState(LeafSystem):
    """Outputs [q; v] desired for the robot's actuated joints at the context's time, from the hold in the
    context. Drake's PiecewisePolynomial holds its end values outside its span; `set_desired` pads the samples
    so the desired velocity is zero before the first and after the last sample."""

    def __init__(self, n: int):
        super().__init__()
        self._n = n
        self._hold = self.DeclareAbstractParameter(AbstractValue.Make(_Hold(np.array([0.0, 1.0]), np.zeros((2, n)))))
        self.DeclareVectorOutputPort("desired_state", 2 * n, self._calc)

    def set_desired(self, context, times: np.ndarray, positions: np.ndarray) -> None:
        """Track `positions` (rows: samples, columns: actuators in desired-state order) at `times`; the first
        sample is held from one second before t = 0 (or before the first sample), the last for 1000 s after."""
        times = np.asarray(times, dtype=float)
        positions = np.asarray(positions, dtype=float)
        padded_times = np.concatenate([[min(0.0, times[0]) - 1.0], times, [times[-1] + 1e3]])
        padded = np.vstack([positions[:1], positions, positions[-1:]])
        context.get_mutable_abstract_parameter(self._hold).set_value(_Hold(padded_times, padded))

    def _calc(self, context, output) -> None:
        hold = context.get_abstract_parameter(self._hold).get_value()
        t = context.get_time()
        output.SetFromVector(np.concatenate([hold.q.value(t)[:, 0], hold.v.value(t)[:, 0]]))


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
