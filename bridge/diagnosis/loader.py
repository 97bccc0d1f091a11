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
from typing import Any, Mapping, Sequence

import numpy as np

from ..recording.adjustments import Adjustment, StartClearance
from .runs import Prepared

NOISE_SIGMAS = 3.0  # one-sided: 0.13 % false alarms per recording under Gaussian noise


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

    def mean_shift(self, names: Sequence[str] | None = None) -> dict[str, float]:
        """The loader's tip shift (m) per robot joint, averaged over `names` (default all) that have a start
        clearance, unshifted ones counting as zero: what a fit over those recordings has already absorbed."""
        chosen = [r for r in self.readings if names is None or r.recording in names]
        if not chosen:
            return {}
        out: dict[str, float] = {}
        for r in chosen:
            for joint, value in zip(r.start.joints, r.start.shift):
                out[joint] = out.get(joint, 0.0) + value / len(chosen)
        return out

    def offset_estimate(self) -> dict[str, float] | None:
        """The calibration offset D (m per joint, true = recorded + D) that explains the penetrations of the
        recordings that started inside: least squares of n_r . D = depth_r (minimum norm, so a direction no
        normal sees stays at zero). None when none started inside."""
        inside = self.inside
        if not inside:
            return None
        normals = np.array([r.start.normal for r in inside])
        depths = np.array([r.start.penetration for r in inside])
        d = np.linalg.lstsq(normals, depths, rcond=None)[0]
        return {joint: float(v) for joint, v in zip(inside[0].start.joints, d)}

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


def raw_offsets(params: Mapping[str, float], shift: Mapping[str, float]) -> dict[str, float]:
    """A fitted pusher offset relative to the raw recording (m per joint): the fitted `joint_offset[j]` plus the
    loader's mean shift of joint j (the fit started from shifted telemetry). Empty when nothing was shifted."""
    if not any(shift.values()):
        return {}
    out = {}
    for name, value in params.items():
        if name.startswith("joint_offset[") and name.endswith("]"):
            joint = name[len("joint_offset["):-1]
            out[joint] = float(value) + shift.get(joint, 0.0)
    return out


def _noise(p: Prepared, obj: str) -> tuple[float, float] | None:
    """(sigma_xy m, sigma_yaw rad) of `obj`'s observed track, as the diagnosis estimated it."""
    for s in p.series:
        if s.object == obj:
            return float(np.mean(s.sigma[:2])), float(s.sigma[5]) if s.measured[5] else 0.0
    return None
