"""Forks: recordings whose outcome the model cannot place, because it turns on less than where the object is known
to be.

A push aimed near a corner goes one way or the other depending on which side of the corner the rod meets: a
millimetre decides 40 degrees of turn. No effect explains that residual, and left as it is one such recording
outweighs every other (on the independent MuJoCo worlds: 120-190 noise floors where the other pushes leave 5-20,
the same with the generator's own parameters in Drake), so fits bend to it and the verdict follows.

The measure: every observed object is replayed shifted by +-PLACEMENT along each of its axes (`frame_x`,
`frame_y`: the object's geometry moved under its recorded frame, so the rod meets it elsewhere and nothing else
changes). For each axis the response d+ (shifted +) and d- (shifted -) of the residual splits into an odd part
(d+ - d-) / 2, which a smooth model turns linearly and which `pusher_offset` and `object_frame` fit, and an even
part (d+ + d-) / 2, half the jump where a shift crosses a fork. A smooth model's even part is second order,
about PLACEMENT^2 / L (hundredths of a millimetre on objects of centimetres; with the simulator's own
discretisation, tenths at most), so a sample has forked where the even parts of both axes, in quadrature, move
the object by more than the shift itself; there they are the fork:
the model's own uncertainty at that sample, added to the noise in quadrature wherever the residual is scored
(`residuals.ObservedSeries.fork`, `ForceSeries.fork` at the same times). A forked push then counts as a residual
of about two tolerances where the model and the world took different branches, and as much as any other push
where it did not fork.

Measured: on the independent rect1 worlds (tilt, patch) the corner pushes' even parts reach 5-15 mm RMS (32-49
noise floors RMS), the others' stay below the shift; on the real ellip3 pushes they stay below 0.2 mm, which
their micrometre motion-capture noise alone would read as 10-70 noise floors: not a fork.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..params import Model, Setting
from .runs import Runner

PLACEMENT = 0.001  # m: how well a recording places an object against what touches it (motion capture and a
#                    robot's calibration, about a millimetre; the MIT pushes' rod-to-outline gaps scatter 0.2-0.5 mm)
KINDS = ("frame_x", "frame_y")


@dataclass(frozen=True)
class Forks:
    """The model's fork per recording (RMS over its scored samples, in tolerances of the noise alone)."""

    placement: float
    size: Mapping[str, float]  # recording -> RMS fork / noise
    failed: tuple[str, ...] = ()  # recordings where a shifted replay failed: their fork is not known
    model: Model = ()  # where they were measured: the calibration the recordings measure (nominal if none)

    def forked(self, level: float = 1.0) -> list[str]:
        """The recordings whose fork is larger than `level` times their noise (RMS)."""
        return [n for n, v in self.size.items() if v > level]

    def sentence(self) -> str:
        forked = self.forked()
        mm = f"{1e3 * self.placement:g} mm"
        at = ("" if not self.model else " (with the " + ", ".join(f"{s.name} = {s.value:.4g}" for s in self.model)
              + " the recordings measure)")
        if not forked:
            return f"no recording forks when its objects are moved by {mm}{at}"
        listed = ", ".join(f"{n} ({self.size[n]:.0f} noise floors)" for n in forked)
        return (f"the model's outcome{at} forks within {mm} of where the objects were recorded in {listed}: "
                f"scored with that fork as part of their tolerance (a corner push, a sticking point)")

    def to_json(self) -> dict:
        return {"placement_m": self.placement, "rms_fork_noise": {n: round(v, 3) for n, v in self.size.items()},
                "forked": self.forked(), "failed": list(self.failed),
                "measured_at": {s.name: s.value for s in self.model}, "note": self.sentence()}


def measure_forks(runner: Runner, indices: Sequence[int], placement: float = PLACEMENT, model: Model = ()) -> Forks:
    """Replay `model` (the nominal one, or the calibration the recordings measure: `identify.measured_model`) with
    every observed object shifted by +-`placement` along x and y, and set each prepared trial's fork
    (`runner.prepared` is updated in place). 4 replays per observed object and recording."""
    pairs, keys = [], []
    for i in indices:
        for s in runner.prepared[i].series:
            for kind in KINDS:
                for sign in (1.0, -1.0):
                    pairs.append(((*model, Setting(kind, s.object, sign * placement)), i))
                    keys.append((i, s.object, kind, sign))
    base = dict(zip(indices, runner.run(tuple(model), indices)))
    shifted = dict(zip(keys, runner.run_pairs(pairs)))
    sizes: dict[str, float] = {}
    failed = []
    for i in indices:
        p = runner.prepared[i]
        parts = [(s.object, kind) for s in p.series for kind in KINDS]
        runs = [(shifted[(i, o, k, 1.0)], shifted[(i, o, k, -1.0)]) for o, k in parts]
        if base[i].failed or any(a.failed or b.failed for a, b in runs):
            failed.append(p.name)
            continue
        even = [_even(base[i].residuals[s.object], [(a.residuals[s.object], b.residuals[s.object]) for a, b in runs])
                for s in p.series]
        forked = [np.linalg.norm(e[:, :3], axis=1) > placement for e in even]
        series = tuple(replace(s, fork=np.where(f[:, None], e, 0.0)) for s, e, f in zip(p.series, even, forked))
        force = p.force
        if force is not None:
            at = np.any([np.interp(force.times, s.times, f.astype(float)) >= 0.5 for s, f in zip(p.series, forked)],
                        axis=0)
            even_force = _even(base[i].force_residual, [(a.force_residual, b.force_residual) for a, b in runs])
            force = replace(force, fork=np.where(at[:, None], even_force, 0.0))
        ratio = np.concatenate([((s.fork[:, s.measured] / s.sigma[s.measured]) ** 2).ravel() for s in series])
        sizes[p.name] = float(np.sqrt(np.mean(ratio)))
        runner.prepared[i] = replace(p, series=series, force=force)
    return Forks(placement, sizes, tuple(failed), tuple(model))


def _even(base: np.ndarray, shifted: Sequence[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """sqrt of the sum over the shifts (+, -) of ((d+ + d-) / 2)^2, d a shifted residual's change from `base`."""
    return np.sqrt(sum(((plus - base + minus - base) / 2) ** 2 for plus, minus in shifted))
