"""What the force and the object's twist say, before any fit: how the object's weight rests on its footprint.

An object slid quasi-statically over a support moves along the normal of its limit surface at the wrench it is
pushed with (Goyal, Ruina, Papadopoulos 1991). In the ellipsoidal approximation of that surface (Lee and Cutkosky
1991; the analytical baseline of `rollout.limit_surface`), the twist (v, omega) of the centre of pressure points
along (F, M / rho^2): F the force on the object, M its moment about that centre, and rho = m_max / f_max the
torsional radius, the largest friction moment over the largest friction force (2/3 of the radius on a uniformly
loaded disc). The recorded force on the object and its recorded track give both sides of that relation at every
sample of a push, so each push that turns its object reads rho (`torsion_radius`: least squares over the angle
between the scaled twist (v, rho omega) and the scaled wrench (F, M / rho)), whatever the friction coefficients,
the mass or the rod's friction (they scale F and M alike).

rho scales with where the weight rests: a footprint scaled by s about its centre (the `pressure_distribution`
effect, `support_scale`) has s times the torsional radius. The ellipsoid is an approximation (a real footprint's
limit surface has flats), and its error depends on the push, so each recording is read against a replay of itself
by the model (uniform pressure over the footprint): the ratio of the two readings of one push is the footprint
scale that push asks for (`SupportReading`), and the pushes' ratios agree when one distribution of weight explains
them all. Only pushes whose wrench turns the object count (INFORMATIVE): a push through the centre says nothing
of torsion.

Neglected: the centre of pressure is taken at the model's centre of mass (an off-centre weight reads as a change of
rho in pushes that turn about it), inertia (a push that starts at speed kicks the object: the samples before it
moves steadily, and the impacts at its start, bias the reading towards translation), and friction that depends on
the sliding speed or the place (read as a different rho per push, and so as pushes that disagree).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import savgol_filter
from scipy.stats import chi2

from ..recording.mitpush import closest_on_outline, touching
from .cone import DISAGREES
from .loader import NOISE_SIGMAS
from .outline import Push, object_outline, recorded_push, replayed_push

RATE = 100.0  # Hz: the tracks, the rod and the force are resampled here before differencing (`work.RATE`)
SMOOTHING = 0.07  # s: the Savitzky-Golay window of the object's twist (`work.SMOOTHING`)
MOVING_SHARE = 0.3  # the object counts as pushed steadily above this share of its 90th-percentile speed (below
#                     it, at the start and the end of a push, the twist is the smoothing's and the inertia's)
MIN_SAMPLES = 15  # pushed samples a recording needs (0.15 s at RATE)
INFORMATIVE = 0.25  # a push reads rho to this relative 1-sigma or better, or it does not count
AGREE = 0.99  # the pushes' ratios agree when their scatter is within this quantile of chi^2 (their own sigmas)
RHO_BOUNDS = (1e-3, 1.0)  # m
# kinds of what the reading neglects: a centre of mass or of pressure moved, a force of the world (a tilt, a post),
# friction not the same everywhere and in every direction; a model with any of them is not judged by it
NEGLECTED = ("com_", "support_x", "support_y", "surface_", "obstacle_", "patch_", "field_", "aniso_")
CALIBRATE = 0.1  # a reading this far from uniform (relative) is replayed once more at its scale to calibrate it


@dataclass(frozen=True)
class Torsion:
    """One push's torsional radius (m) and its 1-sigma."""

    rho: float
    rho_sd: float
    samples: int

    @property
    def informative(self) -> bool:
        return self.rho_sd <= INFORMATIVE * self.rho


def torsion_radius(push: Push, outline: np.ndarray, centre: Sequence[float] = (0.0, 0.0)) -> Torsion | None:
    """rho of one push (module docstring), the centre of pressure at `centre` (body frame x y: the model's centre
    of mass); None with fewer than MIN_SAMPLES samples where the rod presses on the moving object."""
    dt = 1.0 / RATE
    if len(push.times) < 8 or push.times[-1] - push.times[0] < 2 * SMOOTHING:
        return None
    length = max(5, int(round(SMOOTHING / dt)) | 1)
    v = savgol_filter(push.xy, length, 2, deriv=1, delta=dt, axis=0)
    w = savgol_filter(push.yaw, length, 2, deriv=1, delta=dt)
    c, s = np.cos(push.yaw), np.sin(push.yaw)
    rel = push.rod - push.xy
    local = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]])
    _, point, _ = closest_on_outline(local, np.asarray(outline, dtype=float))
    to_world = lambda p: np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]])  # noqa: E731
    arm = to_world(point - np.asarray(centre, dtype=float))  # from the centre of pressure
    lever = to_world(np.broadcast_to(np.asarray(centre, dtype=float), point.shape))  # the centre from the origin
    v = v + w[:, None] * np.column_stack([-lever[:, 1], lever[:, 0]])  # the centre's velocity
    moment = arm[:, 0] * push.force[:, 1] - arm[:, 1] * push.force[:, 0]
    speed = np.hypot(*v.T)
    keep = touching(np.hypot(*push.force.T)) & (speed > MOVING_SHARE * np.percentile(speed, 90))
    if keep.sum() < MIN_SAMPLES:
        return None
    v, w, f, moment = v[keep], w[keep], push.force[keep], moment[keep]

    def residual(x: np.ndarray) -> np.ndarray:
        rho = math.exp(x[0])
        twist = np.column_stack([v, rho * w])
        wrench = np.column_stack([f, moment / rho])
        twist /= np.maximum(np.linalg.norm(twist, axis=1, keepdims=True), 1e-12)
        wrench /= np.maximum(np.linalg.norm(wrench, axis=1, keepdims=True), 1e-12)
        return (twist - wrench).ravel()

    best = None
    for start in (0.01, 0.03, 0.1):  # the angle's misfit is not convex in rho far from the answer
        fit = least_squares(residual, [math.log(start)], bounds=([math.log(RHO_BOUNDS[0])], [math.log(RHO_BOUNDS[1])]))
        if best is None or fit.cost < best.cost:
            best = fit
    J = best.jac
    # neighbouring samples share the smoothed twist: the residuals' variance counts once per smoothing window
    var = 2 * best.cost / max(1, best.fun.size - 1) * length
    curvature = float(J[:, 0] @ J[:, 0])
    log_sd = math.sqrt(var / curvature) if curvature > 0 else math.inf
    rho = math.exp(float(best.x[0]))
    return Torsion(rho, rho * log_sd, int(keep.sum()))


@dataclass(frozen=True)
class PushSupport:
    """One recording's torsional radius as recorded and as the model's replays at footprint scales read it, and the
    scale that push asks for (`scale`: the replays' reading made to match the recorded one, `calibrated`)."""

    recording: str
    recorded: Torsion
    replayed: tuple[tuple[float, Torsion], ...]  # (footprint scale, reading), in the order replayed

    @property
    def scale(self) -> float:
        return calibrated(self.recorded, self.replayed)

    @property
    def log_sd(self) -> float:
        last = self.replayed[-1][1]
        return math.hypot(self.recorded.rho_sd / self.recorded.rho, last.rho_sd / last.rho)


def calibrated(recorded: Torsion, replayed: Sequence[tuple[float, Torsion]]) -> float:
    """The footprint scale whose replay would read `recorded`: from one replay at scale s, s x the ratio of the
    readings (rho taken as proportional to the scale); from two or more, the secant through the last two in logs
    (Drake's own worlds read a footprint scaled by 0.5 as 0.66 against uniform replays: the ellipsoid understates
    a departure from uniform)."""
    (s1, r1) = replayed[-1]
    step = math.log(recorded.rho / r1.rho)
    if len(replayed) > 1:
        s0, r0 = replayed[-2]
        slope = math.log(r1.rho / r0.rho) / math.log(s1 / s0) if s1 != s0 else 0.0
        if slope > 0.2:  # a replay pair that barely moved the reading is no calibration: proportional instead
            step /= slope
    return s1 * math.exp(step)


@dataclass(frozen=True)
class SupportReading:
    """The footprint scale the pushes ask for (the weighted geometric mean of theirs, `PushSupport`) and its
    1-sigma (from their scatter where they disagree), whether one scale explains them all (`agree`), and the scale a
    fit gave (None: the model has the database's uniform footprint)."""

    object: str
    pushes: tuple[PushSupport, ...]
    scale: float
    scale_sd: float
    agree: bool
    fitted: float | None = None
    outside: bool = False  # the model compared has what the reading neglects (NEGLECTED): not judged

    @property
    def contradicts(self) -> bool:
        """The model's footprint scale (1 without a fitted one) is more than NOISE_SIGMAS sigma and DISAGREES of it
        off the reading's, the pushes agree on one, and the model has nothing the reading neglects."""
        model = 1.0 if self.fitted is None else self.fitted
        return (self.agree and not self.outside
                and abs(model - self.scale) > max(NOISE_SIGMAS * self.scale_sd, DISAGREES * self.scale))

    def sentence(self) -> str:
        scales = ", ".join(f"{p.scale:.2f}" for p in sorted(self.pushes, key=lambda p: p.scale))
        head = (f"the force and the twist of {self.object} read its torsional friction in {len(self.pushes)} "
                f"push(es) that turned it, against the model's replays: as if its weight rested on its footprint "
                f"scaled by {self.scale:.2f} +- {self.scale_sd:.2f} (per push {scales})")
        if not self.agree:
            return (head + "; the pushes disagree beyond their noise: no one distribution of weight under the centre "
                    "of mass explains them (an off-centre mass, friction that changes with the place or the speed, "
                    "or an outline that differs from the model's)")
        if self.outside:
            return head + ("; the chosen model has what the reading neglects (a centre of mass or of pressure "
                           "moved, a force of the world, or friction that changes with the place or the direction): "
                           "not compared")
        model = "uniform" if self.fitted is None else f"scaled by {self.fitted:.2f}"
        return head + (f"; the model's footprint ({model}) contradicts it" if self.contradicts
                       else f"; the model's footprint ({model}) agrees with it")

    def to_json(self) -> dict[str, Any]:
        return {"object": self.object, "scale": _g(self.scale), "scale_sd": _g(self.scale_sd), "agree": self.agree,
                "fitted": None if self.fitted is None else _g(self.fitted), "outside": self.outside,
                "contradicts": self.contradicts, "replayed_scales": [_g(s) for s, _ in self.pushes[0].replayed],
                "pushes": [{"recording": p.recording, "scale": _g(p.scale), "log_sd": _g(p.log_sd),
                            "recorded_rho_m": _g(p.recorded.rho),
                            "replayed_rho_m": [_g(t.rho) for _, t in p.replayed]} for p in self.pushes],
                "sentence": self.sentence()}


def _g(value: float) -> float:
    return float(f"{value:.4g}")


def _centre(trials: Sequence, odb, obj: str) -> tuple[float, float]:
    from ..sim.shapes import mass_properties

    com = mass_properties(odb, trials[0].world.objects[obj].type).com
    return float(com[0]), float(com[1])


def recorded_torsions(trials: Sequence, odb, obj: str) -> dict[str, Torsion]:
    """The informative torsional radii of `obj` in `trials` as recorded, by recording name (empty without a force
    track, a planar pusher or a prism outline)."""
    outline = object_outline(trials, odb, obj)
    if outline is None:
        return {}
    centre = _centre(trials, odb, obj)
    out = {}
    for trial in trials:
        push = recorded_push(trial, obj, RATE)
        reading = torsion_radius(push, outline, centre) if push is not None else None
        if reading is not None and reading.informative:
            out[trial.name] = reading
    return out


def support_reading(trials: Sequence, replays: Sequence[tuple[float, Sequence]], odb, obj: str,
                    fitted: float | None = None) -> SupportReading | None:
    """The `SupportReading` of `obj` over `trials` (`rollout.trials.Trial`) and the model's replays of them at one
    or more footprint scales ((scale, `sim.simulate.ReplayResult`s run with `robot_force` and `joint_track`; None
    entries skipped), the last nearest the answer), against a `fitted` scale; None without two pushes informative
    in the recordings and in every replay."""
    outline = object_outline(trials, odb, obj)
    recorded = recorded_torsions(trials, odb, obj)
    centre = _centre(trials, odb, obj) if recorded else (0.0, 0.0)
    pushes = []
    for k, trial in enumerate(trials):
        if trial.name not in recorded:
            continue
        readings = []
        for scale, results in replays:
            push = replayed_push(trial, results[k], obj, RATE)
            reading = torsion_radius(push, outline, centre) if push is not None else None
            if reading is None or not reading.informative:
                break
            readings.append((scale, reading))
        else:
            pushes.append(PushSupport(trial.name, recorded[trial.name], tuple(readings)))
    if len(pushes) < 2:
        return None
    logs = np.log([p.scale for p in pushes])
    weights = 1.0 / np.array([p.log_sd for p in pushes]) ** 2
    mean = float(weights @ logs / weights.sum())
    agree = float(weights @ (logs - mean) ** 2) <= chi2.ppf(AGREE, len(pushes) - 1)
    # where the pushes scatter beyond their sigmas, the scatter is the honest uncertainty of the mean
    log_sd = max(1.0 / math.sqrt(weights.sum()), float(np.std(logs, ddof=1)) / math.sqrt(len(pushes)))
    scale = math.exp(mean)
    return SupportReading(obj, tuple(pushes), scale, scale * log_sd, bool(agree), fitted)


def calibrated_reading(trials: Sequence, uniform: Sequence, replay: Callable[[float], Sequence], odb, obj: str,
                       bounds: tuple[float, float] = (0.3, 1.6)) -> SupportReading | None:
    """`support_reading` against the model's `uniform` replays, read again with `replay(scale)`'s (the replays at
    the first reading, clipped to `bounds`) where the pushes agree on a scale more than CALIBRATE from uniform."""
    support = support_reading(trials, [(1.0, uniform)], odb, obj)
    if support is None or not support.agree or abs(math.log(support.scale)) <= math.log(1.0 + CALIBRATE):
        return support
    scale = float(np.clip(support.scale, *bounds))
    return support_reading(trials, [(1.0, uniform), (scale, replay(scale))], odb, obj) or support
