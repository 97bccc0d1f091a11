"""What the loader changed in each recording, read as evidence (issue 11: never repair away evidence).

The loader must start a rod that was recorded inside the object just clear of it (a simulation cannot start in
penetration), but that repair is an observation: a rod cannot really be inside the object, so a start
penetration beyond what the motion capture and the outline explain means the recorded pusher is not where the
real one was (a calibration offset: `pusher_offset`) or the object model is wrong.

Threshold (per recording): the rod counts as started inside when its penetration exceeds
NOISE_SIGMAS x sigma_start, with sigma_start^2 = sigma_xy^2 + (lever sigma_yaw)^2 + spread^2, where
- sigma_xy, sigma_yaw: the white noise of the object's observed pose estimated from its own track (the noise the
  diagnosis divides every residual by, `residuals.estimate_noise`); the start clearance is read from one pose;
- lever: the distance from the object's centre to the rod at t = 0 (a yaw error moves the outline there by
  lever x yaw);
- spread: the scatter of the same rod-to-outline gap while the rod pushes the object, where the true gap is
  zero (`StartClearance.contact_spread`), as the median over the recordings of that shape: what the outline's
  mismatch with the real object, the rod's own tracking and the motion capture leave in a measured gap. A
  constant calibration offset moves that gap's median, not its scatter, so it does not hide itself; the median
  over recordings, because a push whose rod slides along a curved side or loses contact scatters by
  millimetres on its own (ellip1 at a steep push angle: 3-4 mm), which says nothing about its start.
NOISE_SIGMAS = 3: one-sided, a Gaussian false alarm rate of 0.13 % per recording. Not the spread of the start
clearance across recordings: the robot starts at different distances, and a calibration offset itself spreads
the start clearances of pushes from different sides (+D.n on one side, -D.n on the other), so a threshold from
that spread would grow with the very offset it is meant to reveal. docs/diagnosis.md, "What the loader changed".
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..recording.adjustments import Adjustment, StartClearance
from .runs import Prepared

NOISE_SIGMAS = 3.0  # one-sided: 0.13 % false alarms per recording under Gaussian noise
NEGLIGIBLE = 5e-4  # m: a rod offset or an outline error below this changes nothing a user would act on (the
#                    negligible size of `joint_offset` for a prismatic joint, bridge.params.kinds)


@dataclass(frozen=True)
class ContactFit:
    """What the rod-to-outline gaps while pushing say (`LoaderEvidence.contact_fit`): a constant offset D of the
    recorded rod (true = recorded + D, m, in the joints' x-y order) and an inflation s of the outline (m, > 0:
    the real object, or rod, is larger than modelled), from gap_r = -n_r . D + s over the recordings (least
    squares); their 1-sigma from the fit's leftover scatter (at least the typical scatter within a push); the gaps'
    RMS before and after.

    With a latency tau (s, the `latency` kind's sign: the real rod moved tau later than recorded, so the recorded
    one leads it by tau x its velocity) every gap also falls by tau u_r, u_r the rod's speed into the object while
    it pushed (`StartClearance.contact_speed`): recordings pushed at different speeds measure tau, before any
    simulation and whatever the contact physics. `latency`/`latency_sd` come from gap_r = -n_r . D + s - tau u_r
    (five recordings or more); D and s are taken from that fit only where the latency is evident
    (`latency_evident`), from the three-term fit otherwise."""

    joints: tuple[str, str]
    offset: tuple[float, float]
    inflation: float
    offset_cov: tuple[tuple[float, float], tuple[float, float]]
    inflation_sd: float
    rms_before: float
    rms_after: float
    count: int
    latency: float | None = None
    latency_sd: float | None = None
    speed: float | None = None  # m/s: the median over the recordings of |u_r|, the speed a latency shows at

    @property
    def offset_size(self) -> float:
        return float(np.hypot(*self.offset))

    def offset_sigmas(self) -> float:
        """How many standard deviations D lies from zero (its Mahalanobis length)."""
        D = np.array(self.offset)
        return float(math.sqrt(max(0.0, D @ np.linalg.pinv(np.array(self.offset_cov)) @ D)))

    @property
    def offset_evident(self) -> bool:
        return self.offset_sigmas() > NOISE_SIGMAS and self.offset_size > NEGLIGIBLE

    @property
    def inflation_evident(self) -> bool:
        return abs(self.inflation) > NOISE_SIGMAS * self.inflation_sd and abs(self.inflation) > NEGLIGIBLE

    @property
    def latency_evident(self) -> bool:
        """tau beyond NOISE_SIGMAS of its uncertainty, and leading the rod by more than NEGLIGIBLE at the
        recordings' typical speed (a few milliseconds at 10-100 mm/s move nothing a user would act on)."""
        if self.latency is None or self.latency_sd is None or self.speed is None:
            return False
        return abs(self.latency) > NOISE_SIGMAS * self.latency_sd and abs(self.latency) * self.speed > NEGLIGIBLE

    def to_json(self) -> dict[str, Any]:
        out = {"offset_m": {j: _g(v) for j, v in zip(self.joints, self.offset)},
               "offset_sigmas": _g(self.offset_sigmas()), "offset_evident": self.offset_evident,
               "inflation_m": _g(self.inflation), "inflation_sd_m": _g(self.inflation_sd),
               "inflation_evident": self.inflation_evident,
               "gap_rms_m": [_g(self.rms_before), _g(self.rms_after)], "recordings": self.count}
        if self.latency is not None:
            out.update({"latency_s": _g(self.latency), "latency_sd_s": _g(self.latency_sd),
                        "latency_evident": self.latency_evident, "speed_m_s": _g(self.speed)})
        return out


def _least_squares(A: np.ndarray, b: np.ndarray, floor: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x minimising |A x - b|, its covariance from the leftover scatter (at least `floor`, the typical scatter
    within a push) and the leftover."""
    x, *_ = np.linalg.lstsq(A, b, rcond=None)
    left = b - A @ x
    var = max(float(left @ left) / max(1, len(b) - A.shape[1]), floor ** 2, 1e-12)
    return x, var * np.linalg.pinv(A.T @ A), left


def _g(value: float) -> float:
    return float(f"{value:.4g}")


@dataclass(frozen=True)
class StartReading:
    """One recording's start clearance against its own threshold (m)."""

    recording: str
    start: StartClearance
    threshold: float

    @property
    def inside(self) -> bool:
        return self.start.penetration > self.threshold


@dataclass(frozen=True)
class LoaderEvidence:
    """Every recording's adjustments (by name, in the diagnosis' order) and the start clearances read from them."""

    adjustments: tuple[tuple[str, tuple[Adjustment, ...]], ...]
    readings: tuple[StartReading, ...]
    held_out: frozenset[str] = field(default_factory=frozenset)

    @property
    def inside(self) -> tuple[StartReading, ...]:
        return tuple(r for r in self.readings if r.inside)

    def agreement(self) -> float:
        """Length of the mean unit shift of the recordings that started inside: 1 when the loader moved every one
        the same way (one offset), near 0 when the directions scatter."""
        units = [np.array(r.start.shift) / max(float(np.hypot(*r.start.shift)), 1e-12) for r in self.inside]
        return float(np.linalg.norm(np.mean(units, axis=0))) if units else 0.0

    def contact_fit(self) -> ContactFit | None:
        """The offset, inflation and latency the contact gaps of every recording imply (`ContactFit`); None with
        fewer than three recordings that pushed (three unknowns)."""
        rows = [r for r in self.readings if r.start.contact_gap is not None and r.start.contact_normal is not None]
        if len(rows) < 3:
            return None
        A = np.array([[-r.start.contact_normal[0], -r.start.contact_normal[1], 1.0] for r in rows])
        b = np.array([r.start.contact_gap for r in rows])
        floor = float(np.median([r.start.contact_spread or 0.0 for r in rows]))
        x, cov, left = _least_squares(A, b, floor)
        latency = latency_sd = speed = None
        speeds = [r.start.contact_speed for r in rows]
        if len(rows) >= 5 and all(u is not None for u in speeds):
            x4, cov4, left4 = _least_squares(np.column_stack([A, -np.array(speeds)]), b, floor)
            latency, latency_sd = float(x4[3]), float(math.sqrt(max(cov4[3, 3], 0.0)))
            speed = float(np.median(np.abs(speeds)))
            if abs(latency) > NOISE_SIGMAS * latency_sd and abs(latency) * speed > NEGLIGIBLE:
                x, cov, left = x4, cov4, left4
        return ContactFit(rows[0].start.joints, (float(x[0]), float(x[1])), float(x[2]),
                          ((float(cov[0, 0]), float(cov[0, 1])), (float(cov[1, 0]), float(cov[1, 1]))),
                          float(math.sqrt(max(cov[2, 2], 0.0))), float(np.sqrt(np.mean(b ** 2))),
                          float(np.sqrt(np.mean(left ** 2))), len(rows), latency, latency_sd, speed)

    @property
    def offset_evident(self) -> bool:
        """Some recording started inside beyond its threshold, or the contact gaps imply an offset (`ContactFit`)."""
        fit = self.contact_fit()
        return bool(self.inside) or (fit is not None and fit.offset_evident)

    def offset_estimate(self) -> dict[str, float] | None:
        """The calibration offset D (m per joint, true = recorded + D): the contact gaps' when they make it evident
        (`ContactFit`: every recording that pushed, not only those that started inside), else the one that
        explains the penetrations of the recordings that started inside (least squares of n_r . D = depth_r,
        minimum norm, so a direction no normal sees stays at zero). None when neither shows one."""
        fit = self.contact_fit()
        if fit is not None and fit.offset_evident:
            return {joint: float(v) for joint, v in zip(fit.joints, fit.offset)}
        inside = self.inside
        if not inside:
            return None
        normals = np.array([r.start.normal for r in inside])
        depths = np.array([r.start.penetration for r in inside])
        d = np.linalg.lstsq(normals, depths, rcond=None)[0]
        return {joint: float(v) for joint, v in zip(inside[0].start.joints, d)}

    def sentences(self) -> list[str]:
        """The report's lines: rods that started inside, a rod offset or an outline error the contact gaps show."""
        out = [self.sentence()] if self.sentence() else []
        fit = self.contact_fit()
        if fit is not None and fit.offset_evident:
            D = np.array(fit.offset) * 1e3
            out.append(f"while it pushed, the recorded rod sat off the object's outline by a constant offset: the real "
                       f"rod was at recorded + ({D[0]:+.1f}, {D[1]:+.1f}) mm ({fit.offset_sigmas():.0f} sigma, from "
                       f"{fit.count} recordings; the gap's RMS falls from {fit.rms_before * 1e3:.1f} to "
                       f"{fit.rms_after * 1e3:.1f} mm once it is removed): evidence of a pusher calibration offset")
        if fit is not None and fit.latency_evident:
            lead = "ahead of" if fit.latency > 0 else "behind"
            out.append(f"while it pushed, the recorded rod sat further {'inside' if fit.latency > 0 else 'outside'} "
                       f"the object the faster it moved: it ran {abs(fit.latency) * 1e3:.0f} +- "
                       f"{fit.latency_sd * 1e3:.0f} ms {lead} the real rod "
                       f"({abs(fit.latency) * fit.speed * 1e3:.1f} mm at the recordings' typical "
                       f"{fit.speed * 1e3:.0f} mm/s; from {fit.count} recordings at different speeds): evidence of "
                       "latency between the telemetry and the observations")
        if fit is not None and fit.inflation_evident:
            side = "outside" if fit.inflation > 0 else "inside"
            out.append(f"on every side the rod pushed {abs(fit.inflation) * 1e3:.1f} mm {side} the object's outline "
                       f"(+- {fit.inflation_sd * 1e3:.1f} mm): the object model is suspect (the real object, or the "
                       f"rod, is {'larger' if fit.inflation > 0 else 'smaller'} than modelled, its outline is "
                       f"wrong, or the contact is {'stiffer' if fit.inflation > 0 else 'softer'} than modelled)")
        return out

    def sentence(self) -> str | None:
        """The report's line when rods started inside beyond their thresholds, else None."""
        inside = self.inside
        if not inside:
            return None
        depths = np.array([r.start.penetration for r in inside]) * 1e3
        shift = np.mean([r.start.shift for r in inside], axis=0) * 1e3
        spread = f" ({depths.min():.1f} to {depths.max():.1f} mm)" if len(inside) > 1 else ""
        return (f"the rod started {float(np.median(depths)):.1f} mm inside the object{spread} in {len(inside)} of "
                f"{len(self.readings)} recordings, beyond the {1e3 * float(np.median([r.threshold for r in inside])):.2f}"
                f" mm that the motion-capture noise and the outline's scatter in contact explain ({NOISE_SIGMAS:g} "
                f"sigma; consistent direction: agreement {self.agreement():.2f} of 1, the loader moved the tip by "
                f"x {shift[0]:+.1f} mm, y {shift[1]:+.1f} mm on average to start it clear): evidence of a pusher "
                "calibration offset or a wrong object model")

    def to_json(self) -> dict[str, Any]:
        """diagnosis.json's "adjustments" (per recording) and "evidence" sections."""
        thresholds = {r.recording: r.threshold for r in self.readings}
        recordings = [{"recording": name, "held_out": name in self.held_out,
                       "adjustments": [{**a.to_json(), **({"threshold_m": float(f"{thresholds[name]:.4g}"),
                                                           "inside": a.penetration > thresholds[name]}
                                                          if isinstance(a, StartClearance) and name in thresholds
                                                          else {})} for a in adj]}
                      for name, adj in self.adjustments]
        inside = self.inside
        offset = self.offset_estimate()
        evidence = {"start_inside": {"count": len(inside), "of": len(self.readings), "noise_sigmas": NOISE_SIGMAS,
                                     "recordings": [r.recording for r in inside],
                                     "agreement": round(self.agreement(), 3) if inside else None,
                                     "offset_estimate_m": ({k: float(f"{v:.4g}") for k, v in offset.items()}
                                                           if offset else None),
                                     "sentence": self.sentence()}}
        fit = self.contact_fit()
        evidence["contact"] = None if fit is None else {**fit.to_json(), "sentences": self.sentences()[bool(inside):]}
        return {"adjustments": recordings, "evidence": evidence}


def read_adjustments(prepared: Sequence[Prepared], held_out: Sequence[int] = ()) -> LoaderEvidence:
    """The loader's adjustments of every prepared trial, with each start clearance against its threshold."""
    spreads: dict[str, list[float]] = {}
    for p in prepared:
        for a in p.trial.adjustments:
            if isinstance(a, StartClearance) and a.contact_spread is not None:
                spreads.setdefault(a.object, []).append(a.contact_spread)
    typical = {obj: float(np.median(v)) for obj, v in spreads.items()}
    readings = []
    for p in prepared:
        for a in p.trial.adjustments:
            if isinstance(a, StartClearance):
                threshold = start_threshold(a, _noise(p, a.object), typical.get(a.object, 0.0))
                if threshold is not None:
                    readings.append(StartReading(p.name, a, threshold))
    return LoaderEvidence(tuple((p.name, tuple(p.trial.adjustments)) for p in prepared), tuple(readings),
                          frozenset(prepared[i].name for i in held_out))


def start_threshold(start: StartClearance, noise: tuple[float, float] | None, spread: float) -> float | None:
    """NOISE_SIGMAS x sigma_start (module docstring; `spread` the shape's typical contact scatter, m); None
    without a noise estimate of the object."""
    if noise is None:
        return None
    sigma_xy, sigma_yaw = noise
    return NOISE_SIGMAS * math.sqrt(sigma_xy ** 2 + (start.lever * sigma_yaw) ** 2 + spread ** 2)


def _noise(p: Prepared, obj: str) -> tuple[float, float] | None:
    """(sigma_xy m, sigma_yaw rad) of `obj`'s observed track, as the diagnosis estimated it."""
    for s in p.series:
        if s.object == obj:
            return float(np.mean(s.sigma[:2])), float(s.sigma[5]) if s.measured[5] else 0.0
    return None
