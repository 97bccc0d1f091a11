"""Constant external forces on free bodies, held in the context: how a fit applies a force without rebuilding."""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import BasicVector, LeafSystem
from pydrake.common.value import AbstractValue


class ConstantForces(LeafSystem):
    """Outputs one force per body (world frame, applied at the body's centre of mass), read from a parameter."""

    def __init__(self, bodies: Sequence[tuple[str, object]]):
        super().__init__()
        self._names = [n for n, _ in bodies]
        self._bodies = [b for _, b in bodies]
        self._param = self.DeclareNumericParameter(BasicVector(np.zeros(3 * len(bodies))))
        self.DeclareAbstractOutputPort(
            "forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]), self._calc)

    def set_forces(self, context, forces: Mapping[str, Sequence[float]]) -> None:
        values = np.zeros(3 * len(self._names))
        for i, name in enumerate(self._names):
            if name in forces:
                values[3 * i: 3 * i + 3] = forces[name]
        context.get_mutable_numeric_parameter(self._param).SetFromVector(values)

    def _calc(self, context, output) -> None:
        values = context.get_numeric_parameter(self._param).get_value()
        forces = []
        for i, body in enumerate(self._bodies):
            f = values[3 * i: 3 * i + 3]
            if np.any(f):
                applied = ExternallyAppliedSpatialForce()
                applied.body_index = body.index()
                applied.p_BoBq_B = body.default_com()
                applied.F_Bq_W = SpatialForce(np.zeros(3), f)
                forces.append(applied)
        output.set_value(forces)
