"""Sleeping objects: do not simulate what cannot change.

A teleoperation session is mostly free motion: the robot moves through the air while the objects stand still.
An object that has been at rest for `rest_time` and that nothing moving can reach within the next samples is
*asleep*: its contacts with the fixtures and the other sleeping objects are filtered out in the context (no
contact query with its support, no contact constraint) and it is held where it is: velocity zero and its
weight (and any external force) cancelled by an applied force, so its pose does not change. It wakes, from the
exact state it fell asleep in (its velocity restored), when the robot or an awake object comes within a margin.
(Drake's joint locking would drop its degrees of freedom too, but Drake 1.51 crashes stepping a plant with a
locked body while any contact involves geometry on the world body, drake issue #24773.) When every object sleeps the replay skips Drake's step altogether: the
robot is moved along its desired trajectory (telemetry through any latency), and when something wakes the
dynamic replay resumes from there.

The numbers (docs/rollout.md, "Sleeping objects"):
- at rest: every point of the object's bounding box slower than `rest_speed` for `rest_time` of simulated
  time. 5 mm/s is the speed at which dry friction of mu >= 0.1 stops a sliding object within
  v^2 / (2 mu g) = 0.013 mm; lasting 0.2 s catches a bounce or a slow topple, which accelerate again.
- within reach: the gap between oriented bounding boxes (a lower bound of the distance, from separating axes)
  is below clearance + (closing speed) x 2 checks: a sleeper wakes before anything can touch it.
- the robot is stepped again (it stops following its telemetry kinematically) earlier: when a link comes
  within clearance + speed x (2 checks + the time its PD needs to settle) of an object or a fixture. The
  settling time is `settle_constants` x the slowest PD time constant kd / kp of the robot's actuators: a robot
  that resumes exactly on its telemetry has settled to where the full simulation would have it before it can
  touch anything. Between the two margins the robot is stepped and the objects still sleep (a step of the arm
  alone costs about half a step with one object awake on the table: 88 against 160 ms a simulated second on
  the session benchmark). `clearance` covers the compliant contact layer and the 4 mm proximity of the final
  contacts.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, GeometrySet
from pydrake.multibody.math import SpatialVelocity

from ..values import Contact
from .scene import Scene


@dataclass(frozen=True)
class SleepRules:
    rest_speed: float = 0.005  # m/s at any point of the object's bounding box
    rest_time: float = 0.2  # s of simulated time at rest before falling asleep
    clearance: float = 0.01  # m kept free around a sleeping object whatever the speeds
    settle_constants: float = 5.0  # PD time constants a resumed robot needs to track as the full simulation does
    check_period: float = 0.02  # s of simulated time between checks, at least (a sample's when samples are rarer)


def _gaps(Ca: np.ndarray, Ra: np.ndarray, Ha: np.ndarray, Cb: np.ndarray, Rb: np.ndarray, Hb: np.ndarray) -> np.ndarray:
    """A lower bound of the distance between each of P oriented boxes and each of M others (centres (., 3), axes
    as columns (., 3, 3), half widths (., 3)): the largest gap of their projections onto the six face normals
    of the pair, (P, M); 0 or less when they may overlap."""
    d = Cb[None, :, :] - Ca[:, None, :]
    absM = np.abs(np.einsum("pji,mjk->pmik", Ra, Rb))  # |Ra^T Rb|
    along_a = np.abs(np.einsum("pji,pmj->pmi", Ra, d)) - Ha[:, None, :] - np.einsum("pmik,mk->pmi", absM, Hb)
    along_b = np.abs(np.einsum("mji,pmj->pmi", Rb, d)) - np.einsum("pmik,pi->pmk", absM, Ha) - Hb[None, :, :]
    return np.maximum(along_a.max(axis=2), along_b.max(axis=2))


class Sleepers:
    """Which objects sleep in one running context, and what they held when they fell asleep."""

    def __init__(self, scene: Scene, context, sample_rate: float, rules: SleepRules = SleepRules()):
        self.scene, self.rules = scene, rules
        plant = scene.plant
        self.plant_ctx = plant.GetMyMutableContextFromRoot(context)
        self.sg_ctx = scene.scene_graph.GetMyMutableContextFromRoot(context)
        query = scene.scene_graph.get_query_output_port().Eval(self.sg_ctx)
        owners, X_BO, half = [], [], []  # one row per box: free objects and moving robot links
        welded = {b.index() for b in plant.GetBodiesWeldedTo(plant.world_body())}
        candidates = dict(scene.bodies)
        if scene.robot_instance is not None:
            for index in plant.GetBodyIndices(scene.robot_instance):
                if index not in welded:
                    candidates[scene.body_names[index]] = plant.get_body(index)
        for name, body in candidates.items():
            X_BW = plant.EvalBodyPoseInWorld(self.plant_ctx, body).inverse().GetAsMatrix4()
            for gid in plant.GetCollisionGeometriesForBody(body):
                obb = query.ComputeObbInWorld(gid)
                if obb is not None:
                    owners.append(name)
                    X_BO.append(X_BW @ obb.pose().GetAsMatrix4())
                    half.append(obb.half_width())
        self.names = list(dict.fromkeys(owners))  # bodies with boxes, each once
        self.bodies = [candidates[n] for n in self.names]
        self.owner = np.array([self.names.index(n) for n in owners], dtype=int)
        self.X_BO, self.half = np.array(X_BO).reshape(-1, 4, 4), np.array(half).reshape(-1, 3)
        self.reach = np.array([max(np.linalg.norm(self.X_BO[i, :3, 3]) + np.linalg.norm(self.half[i])
                                   for i in np.flatnonzero(self.owner == k)) for k in range(len(self.names))])
        self.fixed_geometries = [g for b in welded for g in plant.GetCollisionGeometriesForBody(plant.get_body(b))]
        robot = set(plant.GetBodyIndices(scene.robot_instance)) if scene.robot_instance is not None else set()
        fixtures = [g for b in welded - robot for g in plant.GetCollisionGeometriesForBody(plant.get_body(b))]
        fixed = [o for o in (query.ComputeObbInWorld(g) for g in fixtures) if o is not None]  # not the robot's base
        self.fixed = (np.array([o.center() for o in fixed]).reshape(-1, 3),
                      np.array([o.pose().rotation().matrix() for o in fixed]).reshape(-1, 3, 3),
                      np.array([o.half_width() for o in fixed]).reshape(-1, 3))
        self.links = np.array([n not in scene.bodies for n in self.names])[self.owner]  # robot links' boxes
        self._last: tuple | None = None  # (world boxes, speeds) of the last update
        self._free = False  # `robot_free` as of the last update
        self.X_WB = np.tile(np.eye(4), (len(self.bodies), 1, 1))  # each body's pose at the last update
        # checked at most every `check_period` of simulated time (a 250 Hz replay would pay the check 12 times
        # as often as its 50 Hz twin for nothing); the margin covers two checks
        self.check_period = max(1.0 / sample_rate, rules.check_period)
        # two horizons: a sleeper wakes two checks before anything can reach it (`wake_horizon`); the robot is
        # stepped again (leaving the kinematic follower) earlier, as long before as its PD needs to settle from
        # its telemetry to where the full simulation has it (`horizon`), so it arrives settled
        self.wake_horizon = 2.0 * self.check_period
        self.horizon = self.wake_horizon + rules.settle_constants * _pd_time_constant(scene)
        self.checked = -np.inf
        self.asleep: dict[str, np.ndarray] = {}  # name -> spatial velocity [w; v] when it fell asleep
        self.forces = scene.force_source.GetMyMutableContextFromRoot(context) if scene.force_source else None
        self.applied = scene.force_source.forces(self.forces) if self.forces is not None else ({}, {})
        self.held: dict[str, list[Contact]] = {}  # name -> its contacts when it fell asleep
        self.rest_since: dict[str, float] = {}
        self._filter = None

    # --- what the simulation loop asks ---------------------------------------------------------------------
    @property
    def all_asleep(self) -> bool:
        return len(self.asleep) == len(self.scene.bodies)

    def held_contacts(self, t: float) -> list[Contact]:
        """The sleeping objects' contacts as they were when they fell asleep (their state has not changed)."""
        return [Contact(c.body_a, c.body_b, c.force, c.point, t) for cs in self.held.values() for c in cs]

    def speeds(self) -> np.ndarray:
        """Each boxed body's fastest point, |v| + |w| r (m/s), in the order of `names` (a sleeper's is 0)."""
        V = np.zeros((len(self.bodies), 6))
        for k in self._moving():
            V[k] = self.scene.plant.EvalBodySpatialVelocityInWorld(self.plant_ctx, self.bodies[k]).get_coeffs()
        return np.sqrt(np.square(V[:, 3:]).sum(axis=1)) + np.sqrt(np.square(V[:, :3]).sum(axis=1)) * self.reach

    def update(self, t: float, contacts: Callable[[], list[Contact]]) -> bool:
        """Wake what something moving may reach, put to sleep what rests out of reach. `contacts()`: this
        sample's contacts (what a sleeper holds; read only when something falls asleep). Returns whether
        anything changed (nothing between checks)."""
        if t - self.checked < self.check_period - 1e-9:
            return False
        self.checked = t
        speeds = self.speeds()
        index = {n: k for k, n in enumerate(self.names)}
        for name in self.scene.bodies:
            if name in self.asleep or name not in index:
                continue
            if speeds[index[name]] > self.rules.rest_speed:
                self.rest_since.pop(name, None)
            else:
                self.rest_since.setdefault(name, t)
        for k in self._moving():  # a sleeper has not moved since it fell asleep
            self.X_WB[k] = self.scene.plant.EvalBodyPoseInWorld(self.plant_ctx, self.bodies[k]).GetAsMatrix4()
        X_WO = self.X_WB[self.owner] @ self.X_BO
        world = (X_WO[:, :3, 3], X_WO[:, :3, :3])
        self._last = (world, speeds)
        self._free = self._robot_free()
        if self._free:  # only the robot moves, out of the settling horizon: nothing can wake or fall
            return False
        changed, woken = False, True
        while woken:  # a woken object may reach another sleeper
            woken = {self.names[k] for k in self._reached([index[n] for n in self.asleep], world, speeds,
                                                          set(self.asleep))}
            for name in woken:
                self._wake(name)
            changed = changed or bool(woken)
        # objects at rest long enough fall asleep together, unless something that stays awake may reach them
        falling = {n for n, since in self.rest_since.items() if t - since >= self.rules.rest_time - 1e-9}
        staying = True
        while staying and falling:
            staying = {self.names[k] for k in self._reached([index[n] for n in falling], world, speeds,
                                                            set(self.asleep) | falling)}
            falling -= staying
        if falling:
            now = contacts()
            for name in sorted(falling):
                self._sleep(name, now)
            changed = True
        if changed:
            self._refilter()
            self._free = self._robot_free()
        return changed

    def _moving(self) -> list[int]:
        """Indices (into `names`) of the bodies that are not asleep: robot links and awake objects."""
        return [k for k, n in enumerate(self.names) if n not in self.asleep]

    def robot_free(self) -> bool:
        """Whether the replay may skip stepping: every object asleep and no robot link within the settling
        horizon of a fixture (a table or a post the robot may run into) or of an object, as of the last
        `update`. Near an object the robot is stepped while the object still sleeps (it wakes later, within
        `wake_horizon`): the robot then touches it as the full simulation's robot would."""
        return self._free

    def _robot_free(self) -> bool:
        if not self.all_asleep or self._last is None:
            return False
        if not self.links.any():
            return True
        (C, R), speeds = self._last
        C_f, R_f, H_f = self.fixed
        objects = ~self.links
        C_o, R_o, H_o = (np.concatenate([C_f, C[objects]]), np.concatenate([R_f, R[objects]]),
                         np.concatenate([H_f, self.half[objects]]))
        if not len(C_o):
            return True
        links = self.links
        margin = self.rules.clearance + speeds[self.owner[links]][:, None] * self.horizon
        return not np.any(_gaps(C[links], R[links], self.half[links], C_o, R_o, H_o) < margin)

    def wake_all(self) -> bool:
        """Everything awake and every filter gone: the context as the full simulation would have it. Returns
        whether anything changed."""
        self._last, self._free = None, False
        if not self.asleep:
            return False
        for name in list(self.asleep):
            self._wake(name)
        self._refilter()
        return True

    # --- internals -------------------------------------------------------------------------------------
    def _reached(self, targets: list[int], world: tuple[np.ndarray, np.ndarray], speeds: np.ndarray,
                 still: set[str]) -> set[int]:
        """Which of the bodies `targets` (indices into `names`) a body that may move (a robot link, an object not
        in `still`) can reach within the margin."""
        chosen = np.zeros(len(self.names), dtype=bool)
        chosen[targets] = True
        rows = chosen[self.owner]
        cols = np.array([n not in still for n in self.names])[self.owner]
        if not rows.any() or not cols.any():
            return set()
        (C, R), H, owner = world, self.half, self.owner
        margin = (self.rules.clearance
                  + (speeds[owner[rows]][:, None] + speeds[owner[cols]][None, :]) * self.wake_horizon)
        hit = (_gaps(C[rows], R[rows], H[rows], C[cols], R[cols], H[cols]) < margin).any(axis=1)
        return set(owner[rows][hit].tolist())

    def _sleep(self, name: str, contacts: list[Contact]) -> None:
        plant, body = self.scene.plant, self.scene.bodies[name]
        # a copy: Drake returns a reference into the context's cache, gone once the context changes
        velocity = plant.EvalBodySpatialVelocityInWorld(self.plant_ctx, body).get_coeffs().copy()
        self.held[name] = [c for c in contacts if name in (c.body_a, c.body_b)
                           and (c.other(name) in self.asleep or c.other(name) not in self.names)]
        self.asleep[name] = velocity
        self.rest_since.pop(name, None)
        plant.SetFreeBodySpatialVelocity(self.plant_ctx, body, SpatialVelocity(np.zeros(6)))

    def _wake(self, name: str) -> None:
        plant, body = self.scene.plant, self.scene.bodies[name]
        plant.SetFreeBodySpatialVelocity(self.plant_ctx, body, SpatialVelocity(self.asleep.pop(name)))
        self.held.pop(name, None)
        self.rest_since.pop(name, None)
        for other in list(self.held):  # contacts with the woken object are computed again
            self.held[other] = [c for c in self.held[other] if name not in (c.body_a, c.body_b)]

    def _refilter(self) -> None:
        """One transient declaration: no contact among sleeping objects and whatever is welded to the world; and
        the forces that hold the sleepers (their weight cancelled at their centre of mass, external forces
        off)."""
        if self.forces is not None:
            plant = self.scene.plant
            forces, points = dict(self.applied[0]), dict(self.applied[1])
            g = plant.gravity_field().gravity_vector()
            for name in self.asleep:
                body = self.scene.bodies[name]
                forces[name] = -body.get_mass(self.plant_ctx) * g
                points[name] = body.CalcCenterOfMassInBodyFrame(self.plant_ctx)
            self.scene.force_source.set_forces(self.forces, forces, points)
        manager = self.scene.scene_graph.collision_filter_manager(self.sg_ctx)
        if self._filter is not None:
            manager.RemoveDeclaration(self._filter)
            self._filter = None
        if self.asleep:
            ids = [g for n in self.asleep for g in self.scene.geometries[n]] + self.fixed_geometries
            self._filter = manager.ApplyTransient(CollisionFilterDeclaration().ExcludeWithin(GeometrySet(ids)))


def _pd_time_constant(scene: Scene) -> float:
    """The slowest time constant kd / kp of the robot's PD actuators (0 without a robot)."""
    plant = scene.plant
    if scene.robot_instance is None:
        return 0.0
    constants = []
    for a in plant.GetJointActuatorIndices(scene.robot_instance):
        actuator = plant.get_joint_actuator(a)
        if actuator.has_controller():
            gains = actuator.get_controller_gains()
            constants.append(gains.d / gains.p if gains.p > 0 else 0.0)
    return max(constants, default=0.0)
