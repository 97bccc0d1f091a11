"""The analytical baseline of quasi-static planar pushing: the ellipsoidal limit surface (Goyal, Ruina,
Papadopoulos 1991; Lynch, Maekawa, Tanie 1992), as used on the MIT pushing data by Yu et al. (IROS 2016) and
Bauza & Rodriguez (2017). It says what a push does without Drake, so a Drake replay can be judged against the
model the literature measures first.

Model (object frame, origin at the centre of pressure, i.e. the outline's area centroid for uniform pressure):

    limit surface     H(F) = (fx^2 + fy^2) / f_max^2 + m^2 / m_max^2 = 1,   f_max = mu_s N
    ratio             c = m_max / f_max = (1/A) integral over the outline of |r| dA     (uniform pressure)
    twist             V = (vx, vy, w) is normal to H:  V ~ (fx, fy, m / c^2),  m = r x f = q . f,  q = (-ry, rx)
    contact velocity  v_c = v + w q = B f,   B = I + q q^T / c^2   (positive definite)
    motion cone       the friction cone's edges f_+- = n + -mu_p t  map to v_+- = B f_+-
    sticking          v_p inside the motion cone:  f = B^-1 v_p = v_p - q (q . v_p) / (c^2 + |q|^2)
    sliding           otherwise f = kappa f_b on the edge b nearer v_p, kappa = (v_p . n) / (B f_b . n):
                      the normal velocities agree, the rod slides along the outline
    force             F = f_max f / sqrt(|f|^2 + (q . f)^2 / c^2)  (on the limit surface); `load` = F / f_max

n is the inward contact normal, t the tangent, r the contact point. The object moves only while the rod (a disk of
radius `PUSHER_RADIUS`, the recorded tip path its centre) overlaps the outline; each step of the path the rod's
motion relative to the object is replaced by the penetration along n plus its tangential part, so the contact is
restored to first order every step and never drifts. The surface coefficient mu_s scales the force only: the
poses do not depend on it (quasi-static), only `load` x mu_s m g does. What the model neglects: inertia (the
slide-on after the rod stops), pressure other than uniform, anisotropic and place-dependent friction, a limit
surface that is not an ellipsoid, and the rod's own compliance.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np
from scipy.optimize import least_squares

from ..errors import LimitSurfaceError, RecordingError
from ..odb import ObjectDatabase
from ..recording.mitpush import PUSHER_RADIUS, closest_on_outline
from ..sim.prisms import outline_of
from ..sim.prisms import centroid, signed_area
from ..sim.simulate import ReplayResult
from ..values import GRAVITY
from .compare import DEFAULT_C, PoseError, error_of_residuals, least_squares_vector, observed_residuals
from .trials import Trial

MU_P_BOUNDS = (0.01, 1.5)  # pusher-object friction a fit may choose
C_SCALE_BOUNDS = (0.3, 1.5)  # factor on the uniform pressure's c a fit may choose (0: all at the centre)
_EPS = 1e-12


@dataclass(frozen=True, eq=False)
class LimitSurface:
    """The ellipsoidal limit surface of a flat object under uniform pressure: its outline (K, 2) m,
    counter-clockwise, in the object's frame; the centre of pressure (the area centroid); area (m^2); and
    c = m_max / f_max (m), the mean distance of the support from the centre of pressure."""

    outline: np.ndarray
    centre: np.ndarray
    area: float
    c: float


@dataclass(frozen=True, eq=False)
class QuasiStaticPush:
    """Poses of the pushed object for B friction values at the pusher path's N times: `poses` (B, N, 3) x, y, yaw
    of the object's frame in the world; `contact` and `sliding` (B, N) say whether the step ending at sample k
    touched and slid at the rod; `load` (B, N, 2) is the force on the object over f_max = mu_s m g (world)."""

    times: np.ndarray
    poses: np.ndarray
    contact: np.ndarray
    sliding: np.ndarray
    load: np.ndarray
    mu_p: np.ndarray


# --- the limit surface of an outline ------------------------------------------------------------------------
def limit_surface_of(outline: np.ndarray, *, source: str | None = None) -> LimitSurface:
    """The limit surface of a flat object pressing uniformly over `outline` (K >= 3 vertices, m, any winding).

    c = (1/A) integral |r| dA about the centroid, exactly: the polygon is a signed fan of triangles from the
    centroid, and over the triangle (0, a, b) with edge line at distance h, s the position along it,
    integral |r| dA = (1/3) [H(s_b) - H(s_a)],  H(s) = (h s sqrt(h^2 + s^2) + h^3 asinh(s / h)) / 2.
    """
    points = np.asarray(outline, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 3:
        raise LimitSurfaceError(f"outline must be K x 2 vertices with K >= 3, got shape {points.shape}",
                                source=source, field="outline")
    if not np.all(np.isfinite(points)):
        raise LimitSurfaceError("outline has non-finite vertices", source=source, field="outline")
    area = signed_area(points)
    if abs(area) < 1e-12:
        raise LimitSurfaceError("outline encloses no area (collinear or repeated vertices)", source=source,
                                field="outline")
    centre = centroid(points)
    if area < 0:
        points, area = points[::-1].copy(), -area
    c = _mean_distance(points - centre) / area
    points.setflags(write=False)
    centre.setflags(write=False)
    return LimitSurface(points, centre, area, float(c))


def _mean_distance(points: np.ndarray) -> float:
    """integral |r| dA over the polygon (counter-clockwise, about the origin), by the signed fan."""
    a, b = points, np.roll(points, -1, axis=0)
    edge = b - a
    length = np.linalg.norm(edge, axis=1)
    keep = length > _EPS
    a, edge, length = a[keep], edge[keep], length[keep]
    u = edge / length[:, None]
    cross = a[:, 0] * edge[:, 1] - a[:, 1] * edge[:, 0]
    h = np.abs(cross) / length
    s_a = np.sum(a * u, axis=1)
    s_b = s_a + length

    def H(s: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            value = 0.5 * (h * s * np.sqrt(h * h + s * s) + h ** 3 * np.arcsinh(s / h))
        return np.where(h > _EPS, value, 0.0)

    return float(np.sum(np.sign(cross) * (H(s_b) - H(s_a)) / 3.0))


# --- the motion of one step ---------------------------------------------------------------------------------
def motion_twist(r: np.ndarray, normal: np.ndarray, v_p: np.ndarray, c: float,
                 mu_p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Object twists (B, 3) (vx, vy about the centre of pressure, w; object frame) for a rod moving the contact
    point `r` (B, 2) at `v_p` (B, 2) with inward normal `normal` (B, 2) and pusher friction `mu_p` (B,); also
    whether the contact slides (B,) and the force over f_max (B, 2). Rows with v_p . n <= 0 do not move."""
    n = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    t = np.column_stack([-n[:, 1], n[:, 0]])
    q = np.column_stack([-r[:, 1], r[:, 0]])
    c2 = c * c
    mu = np.broadcast_to(np.asarray(mu_p, dtype=float), (len(r),))[:, None]

    def contact_velocity(f: np.ndarray) -> np.ndarray:  # B f
        return f + q * (np.sum(q * f, axis=1, keepdims=True) / c2)

    f_plus, f_minus = n + mu * t, n - mu * t
    v_plus, v_minus = contact_velocity(f_plus), contact_velocity(f_minus)
    side = np.sign(_cross(v_minus, v_plus))
    beyond_plus = _cross(v_p, v_plus) * side < 0  # v_p turned past v_plus
    beyond_minus = _cross(v_minus, v_p) * side < 0
    sliding = beyond_plus | beyond_minus
    stick = v_p - q * (np.sum(q * v_p, axis=1, keepdims=True) / (c2 + np.sum(q * q, axis=1, keepdims=True)))
    edge = np.where(beyond_plus[:, None], f_plus, f_minus)
    edge_normal = np.maximum(np.sum(contact_velocity(edge) * n, axis=1, keepdims=True), _EPS)
    slide = edge * (np.sum(v_p * n, axis=1, keepdims=True) / edge_normal)
    f = np.where(sliding[:, None], slide, stick)
    pushing = np.sum(v_p * n, axis=1) > 0
    f = np.where(pushing[:, None], f, 0.0)
    m = np.sum(q * f, axis=1)
    twist = np.column_stack([f, m / c2])
    norm = np.sqrt(np.sum(f * f, axis=1) + m * m / c2)
    load = np.where(norm[:, None] > _EPS, f / np.maximum(norm, _EPS)[:, None], 0.0)
    return twist, sliding & pushing, load


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


# --- a whole push ---------------------------------------------------------------------------------------------
def push_object(surface: LimitSurface, times: np.ndarray, tip: np.ndarray, start: Sequence[float], *,
                mu_p: float | Sequence[float], pusher_radius: float = PUSHER_RADIUS,
                source: str | None = None) -> QuasiStaticPush:
    """Integrate the object's pose (x, y, yaw; its frame in the world, `start` at times[0]) along the rod's
    centre path `tip` (N, 2) m at `times` (N,) s, for each pusher friction in `mu_p` at once (the batch)."""
    times = np.asarray(times, dtype=float)
    tip = np.asarray(tip, dtype=float)
    mus = np.atleast_1d(np.asarray(mu_p, dtype=float))
    start = np.asarray(start, dtype=float)
    if times.ndim != 1 or len(times) < 2 or tip.shape != (len(times), 2):
        raise LimitSurfaceError(f"the pusher path needs N >= 2 times and N x 2 positions, got {times.shape} and "
                                f"{tip.shape}", source=source, field="tip")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(tip))) or np.any(np.diff(times) <= 0):
        raise LimitSurfaceError("the pusher path must be finite with increasing times", source=source, field="tip")
    if start.shape != (3,) or not np.all(np.isfinite(start)):
        raise LimitSurfaceError(f"start must be a finite (x, y, yaw), got {start.tolist()}", source=source,
                                field="start")
    if mus.ndim != 1 or not np.all(np.isfinite(mus)) or np.any(mus < 0):
        raise LimitSurfaceError(f"mu_p must be finite coefficients >= 0, got {mus.tolist()}", source=source,
                                field="mu_p")
    if not (math.isfinite(pusher_radius) and pusher_radius >= 0):
        raise LimitSurfaceError(f"pusher_radius must be a finite number >= 0 m, got {pusher_radius!r}",
                                source=source, field="pusher_radius")
    B, N = len(mus), len(times)
    poses = np.empty((B, N, 3))
    contact = np.zeros((B, N), dtype=bool)
    sliding = np.zeros((B, N), dtype=bool)
    load = np.zeros((B, N, 2))
    pose = np.tile(start, (B, 1))
    poses[:, 0] = pose
    centre = surface.centre
    for k in range(N - 1):
        cos, sin = np.cos(pose[:, 2]), np.sin(pose[:, 2])
        rel = tip[k + 1] - pose[:, :2]
        local = np.column_stack([cos * rel[:, 0] + sin * rel[:, 1], -sin * rel[:, 0] + cos * rel[:, 1]])
        distance, nearest, outward = closest_on_outline(local, surface.outline)
        touching = distance < pusher_radius
        if touching.any():
            step = tip[k + 1] - tip[k]
            step_local = np.column_stack([cos * step[0] + sin * step[1], -sin * step[0] + cos * step[1]])
            n = -outward
            t = np.column_stack([-n[:, 1], n[:, 0]])
            v_p = n * (pusher_radius - distance)[:, None] + t * np.sum(step_local * t, axis=1, keepdims=True)
            twist, slid, f = motion_twist(nearest - centre, n, v_p, surface.c, mus)
            twist[~touching] = 0.0
            heading = pose[:, 2] + 0.5 * twist[:, 2]  # midpoint rule for the translation
            ch, sh = np.cos(heading), np.sin(heading)
            moved_centre = pose[:, :2] + np.column_stack([cos * centre[0] - sin * centre[1],
                                                          sin * centre[0] + cos * centre[1]])
            moved_centre += np.column_stack([ch * twist[:, 0] - sh * twist[:, 1], sh * twist[:, 0] + ch * twist[:, 1]])
            yaw = pose[:, 2] + twist[:, 2]
            cy, sy = np.cos(yaw), np.sin(yaw)
            pose = np.column_stack([moved_centre[:, 0] - (cy * centre[0] - sy * centre[1]),
                                    moved_centre[:, 1] - (sy * centre[0] + cy * centre[1]), yaw])
            contact[:, k + 1] = touching
            sliding[:, k + 1] = slid & touching
            load[:, k + 1] = np.where(touching[:, None],
                                      np.column_stack([cos * f[:, 0] - sin * f[:, 1], sin * f[:, 0] + cos * f[:, 1]]),
                                      0.0)
        poses[:, k + 1] = pose
    return QuasiStaticPush(times, poses, contact, sliding, load, mus)


# --- MIT trials -------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PushedObject:
    """The object a trial pushes: its name, limit surface, start pose (x, y, yaw of the mesh frame, as the
    trial's world has it), height of its centre (m) and mass (kg, from the outline, thickness and density)."""

    name: str
    surface: LimitSurface
    start: tuple[float, float, float]
    z: float
    mass: float


def pushed_object(trial: Trial, odb: ObjectDatabase, *, thickness: float = 0.0128) -> PushedObject:
    """The observed free object of a planar push and its outline (`prisms.outline_of` its geometry);
    the trial's world already holds the frame yaw (`load_trials`)."""
    moving = [tr.object for tr in trial.observations if tr.object in trial.world.objects
              and not odb.get(trial.world.objects[tr.object].type).fixed]
    if len(moving) != 1:
        raise RecordingError(f"the limit-surface baseline needs one observed free object, the trial has "
                             f"{len(moving)} ({', '.join(moving) or 'none'})", source=str(trial.source))
    name = moving[0]
    state = trial.world.objects[name]
    kind = odb.get(state.type)
    outline = outline_of(kind.geometry) if kind.geometry is not None else None
    if outline is None:
        raise RecordingError(f"object {name!r} (type {state.type}) is no prism (a box, a cylinder or an extruded "
                             "outline mesh), so it has no outline for the limit surface", source=str(trial.source))
    surface = limit_surface_of(outline, source=f"{state.type} outline")
    density = kind.physics.density
    mass = float(kind.physics.mass) if kind.physics.mass is not None else float(density) * surface.area * thickness
    x, y, z = state.pose.xyz
    return PushedObject(name, surface, (float(x), float(y), float(state.pose.yaw())), float(z), mass)


def push_trial(trial: Trial, pushed: PushedObject, mu_p: float | Sequence[float]) -> QuasiStaticPush:
    """The limit-surface prediction of a trial: the rod follows the trial's telemetry (`pusher_x`, `pusher_y`,
    already moved out of the object at t = 0 as the Drake replay has it)."""
    telemetry = trial.telemetry.select(("pusher_x", "pusher_y"))
    return push_object(pushed.surface, telemetry.times, telemetry.positions, pushed.start, mu_p=mu_p,
                       source=str(trial.source))


def push_residuals(trial: Trial, pushed: PushedObject, push: QuasiStaticPush) -> list[list[np.ndarray]]:
    """Per batch member, the trial's (n, 6) residuals (`compare.observed_residuals`) against the prediction."""
    out = []
    for b in range(len(push.mu_p)):
        yaw = push.poses[b, :, 2]
        track = np.column_stack([push.poses[b, :, 0], push.poses[b, :, 1], np.full(len(yaw), pushed.z),
                                 np.cos(yaw / 2), np.zeros(len(yaw)), np.zeros(len(yaw)), np.sin(yaw / 2)])
        result = ReplayResult(times=push.times, tracks={pushed.name: track}, final_contacts=(), contact_log=(),
                              moved=(), touched_by_robot=(), max_tracking_error=0.0,
                              sim_time=float(push.times[-1]), wall_time=0.0)
        out.append(observed_residuals(trial.observations, {pushed.name}, trial.telemetry.end, result))
    return out


def surface_friction_from_force(trial: Trial, pushed: PushedObject, push: QuasiStaticPush) -> float | None:
    """mu_s that best matches the recorded pusher force (least squares; the force on the rod is -mu_s m g load),
    for the first batch member; None when the trial has no trusted force or the model never pushes."""
    if trial.force is None:
        return None
    predicted = np.column_stack([np.interp(trial.force.times, push.times, push.load[0, :, k]) for k in range(2)])
    unit = pushed.mass * GRAVITY * predicted
    scale = float(np.sum(unit * unit))
    if scale <= _EPS:
        return None
    return max(0.0, float(-np.sum(trial.force.force[:, :2] * unit) / scale))


@dataclass(frozen=True)
class FrictionFit:
    """What minimises the paper's error E over some trials: the pusher friction and, when fitted, the factor on
    the uniform pressure's c (`c_scale` < 1: pressure nearer the centre); E before (at the start) and after."""

    mu_p: float
    c_scale: float
    before: PoseError
    after: PoseError
    evaluations: int


def fit_pusher_friction(trials: Sequence[Trial], pushed: Sequence[PushedObject], mu_p0: float, *,
                        fit_pressure: bool = False, c: float = DEFAULT_C, bounds: tuple[float, float] = MU_P_BOUNDS,
                        max_evaluations: int = 30) -> FrictionFit:
    """mu_p (and with `fit_pressure` a factor on c) by scipy's bounded least squares on the paper's error
    (eq. 1-4, `compare.least_squares_vector`) over `trials`. mu_s is not fitted here: quasi-static poses do not
    depend on it (`surface_friction_from_force`). `max_evaluations` is scipy's `max_nfev` (the
    finite-difference Jacobian's evaluations come on top)."""
    if not trials or len(trials) != len(pushed):
        raise LimitSurfaceError(f"fit_pusher_friction needs trials and their pushed objects, one each; got "
                                f"{len(trials)} and {len(pushed)}")
    lo, hi = bounds
    evaluations = 0

    def rows(x: Sequence[float]) -> list[np.ndarray]:
        nonlocal evaluations
        evaluations += 1
        scale = float(x[1]) if len(x) > 1 else 1.0
        out = []
        for trial, p in zip(trials, pushed):
            if scale != 1.0:
                p = replace(p, surface=replace(p.surface, c=p.surface.c * scale))
            out.extend(push_residuals(trial, p, push_trial(trial, p, float(x[0])))[0])
        return out

    start = [min(hi, max(lo, float(mu_p0)))] + ([1.0] if fit_pressure else [])
    lower, upper = [lo] + ([C_SCALE_BOUNDS[0]] if fit_pressure else []), [hi] + ([C_SCALE_BOUNDS[1]] if fit_pressure else [])
    solution = least_squares(lambda x: least_squares_vector(rows(x), c), start, bounds=(lower, upper),
                             diff_step=1e-2, max_nfev=max_evaluations, x_scale=[0.1] * len(start))
    best = [float(v) for v in solution.x]
    return FrictionFit(best[0], best[1] if fit_pressure else 1.0, error_of_residuals(rows(start), c),
                       error_of_residuals(rows(best), c), evaluations)
