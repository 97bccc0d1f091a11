"""`object_frame`: the recording tracks a frame on the object other than the one its model is built around (a
motion-capture body defined from markers off the object's centre, a mesh whose origin is not the tracked one, a
frame turned by a few degrees). An error of the object model, not of the physics: the real object is pushed where
its outline really is, but the recorded poses, and the start pose the replay begins from, are those of another
point, turned.

Modelled by the kinds `frame_x`, `frame_y`, `frame_yaw` (`params.kinds.ObjectFrame`): the body starts at the
recorded start pose moved by the inverse of the frame's pose, and its poses are compared with the recording in
the recorded frame. What it leaves: the rod meets the outline elsewhere than simulated (earlier on one side, later
on the other, a different lever arm, so a different turn), and while the object turns the recorded point moves on
an arc about the true centre (position residual growing with the turn, across the push, from the first contact
on); a rod that starts inside the modelled outline on one side and clear of it on the other.
"""
from __future__ import annotations

import math

import numpy as np

from ...values import Pose
from .base import Effect, Evidence, Recovery, Truth, movable_observed, pname

SIZES = ((0.003, 0.035), (0.006, 0.07), (0.010, 0.12))  # the proof's offsets (m) and turns (rad), small to large
SEED_TURN = 0.07  # rad (4 deg): the turned seeds, the proof's medium turn, halfway to the search's 20 deg
RECOVERED = (0.3, 0.001, 0.0175)  # share of the concealed offset and turn, plus 1 mm and 1 deg


def frame_pose(x: float, y: float, yaw: float) -> Pose:
    """X_BR: the recorded frame in the body frame, a planar offset and a turn about the vertical."""
    return Pose((float(x), float(y), 0.0), (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)))


class ObjectFrameEffect(Effect):
    name = "object_frame"
    summary = "the recording tracks a frame on the object off (and turned from) the one its model is built around"
    mechanism = "poses: the body starts at the recorded pose moved by the frame's inverse, compared in that frame"
    signature_text = ("from the first contact on, the rod meets the outline elsewhere than simulated and the "
                      "recorded point swings across the push as the object turns; rods that start inside the "
                      "modelled outline")
    kinds = ("frame_x", "frame_y", "frame_yaw")

    def targets(self, world, odb, observed):
        return movable_observed(world, odb, observed)

    def signature(self, evidence: Evidence, target: str) -> float:
        """Early onset and an across-push residual, raised by the share of recordings whose rod started inside the
        modelled outline (a rod the tracker puts inside the object is the mark of a frame or a rod offset), and to
        1 when the pushing samples put the rod on the outline only with the frame moved (`diagnosis.outline`)."""
        if evidence.frame and any(k.endswith(f"[{target}]") for k in evidence.frame):
            return 1.0
        early = 1.0 - min(1.0, max(0.0, evidence.mean("onset_rel", 0.0)))
        base = 0.15 + 0.3 * early * evidence.mean("across") + 0.1 * early
        return base + (0.6 - base) * min(1.0, max(0.0, evidence.started_inside))

    def seeds(self, evidence: Evidence, target: str) -> list[dict[str, float]]:
        """The frame the pushing samples imply when they make it evident (`diagnosis.outline`), the null frame and
        the frame turned either way by SEED_TURN: the offset is a smooth function of the
        residual (the recorded point's arc as the object turns), the turn is not (it acts only through where the rod
        meets the outline, and a rectangle's face turned either way can look alike from the null)."""
        null = self.null_values(evidence.world, evidence.odb, target)
        yaw = pname("frame_yaw", target)
        seeds = [null, {**null, yaw: -SEED_TURN}, {**null, yaw: SEED_TURN}]
        read = {k: v for k, v in (evidence.frame or {}).items() if k in null}
        return [{**null, **read}] + seeds if read else seeds

    def describe(self, world, odb, target, values):
        x, y = values.get(pname("frame_x", target), 0.0), values.get(pname("frame_y", target), 0.0)
        return {"offset_mm": 1e3 * math.hypot(x, y), "turn_deg": math.degrees(values.get(pname("frame_yaw", target), 0.0))}

    # --- the proof: the tracker's frame set off the object's centre and turned -------------------------------
    def draw_truth(self, scene, odb, rng, magnitude, sign):
        size, turn = SIZES[magnitude]
        angle = rng.uniform(-math.pi, math.pi)
        return Truth(self.name, scene.object, {pname("frame_x", scene.object): size * math.cos(angle),
                                               pname("frame_y", scene.object): size * math.sin(angle),
                                               pname("frame_yaw", scene.object): sign * turn},
                     "the motion capture's frame defined off the object's centre and turned")

    def conceal(self, truth, scene, odb, rollout):
        """Nothing changes in the world: the object is where it is. The recorder reports another frame on it
        (`recorded_track`), and the recording's start pose is that frame's."""
        return rollout, rollout.telemetry

    def recorded_track(self, truth: Truth, track: np.ndarray) -> np.ndarray:
        """What the motion capture reports of the true (T, 7) body track: the frame X_BR fixed on the body."""
        from ...sim.simulate import frame_track

        o = truth.target
        return frame_track(track, frame_pose(truth.params[pname("frame_x", o)], truth.params[pname("frame_y", o)],
                                             truth.params[pname("frame_yaw", o)]))

    def recovered(self, truth, found, model, world, odb):
        o = truth.target
        want = np.array([truth.params[pname(k, o)] for k in ("frame_x", "frame_y")])
        got = np.array([found.get(pname(k, o), 0.0) for k in ("frame_x", "frame_y")])
        d = float(np.linalg.norm(got - want))
        turn = truth.params[pname("frame_yaw", o)]
        d_yaw = abs(found.get(pname("frame_yaw", o), 0.0) - turn)
        share, mm, deg = RECOVERED
        ok = d <= share * float(np.linalg.norm(want)) + mm and d_yaw <= share * abs(turn) + deg
        return Recovery(ok, d, "m", f"offset {1e3 * d:.1f} mm off a {1e3 * np.linalg.norm(want):.1f} mm one, turn "
                                    f"{math.degrees(d_yaw):.1f} deg off {math.degrees(turn):.1f} (30 % + 1 mm, 1 deg)")
