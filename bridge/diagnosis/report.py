"""What a diagnosis writes: diagnosis.json (schema: diagnosis.schema.json), report.md and plots."""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, BinaryIO, Mapping, Sequence

import numpy as np

from ..files import Content, write_set
from .crossval import ALIKE_P
from .identify import CV_GAIN, Identification, _error_json
from .locate import Localisation, LocatedObject

SCHEMA_PATH = Path(__file__).with_name("diagnosis.schema.json")
MAX_RESIDUAL_PLOTS = 6


def load_schema() -> dict:
    return json.loads(SCHEMA_PATH.read_text())


def diagnosis_json(ident: Identification, *, scene_file: str | None = None, noise: Mapping[str, float] | None = None,
                   failures: Mapping[str, Any] | None = None) -> dict[str, Any]:
    winner, runner = ident.winner, ident.runner_up
    none = next(s for s in ident.ranked if s.effect == "none")
    error: dict[str, Any] = {"before": {**_error_json(none.error), "rms_sigma": round(none.rms, 4)},
                             "after": {**_error_json(winner.error), "rms_sigma": round(winner.rms, 4)},
                             "reduction": _reduction(none.error, winner.error),
                             "excess_reduction": excess_reduction(none.rms, winner.rms)}
    if ident.held_out:
        before, after = held_out_rms(none), held_out_rms(winner)
        error.update({"held_out_before": {**_error_json(none.held_out_error), "rms_sigma": _round4(before)},
                      "held_out_after": {**_error_json(winner.held_out_error), "rms_sigma": _round4(after)},
                      "held_out_reduction": _reduction(none.held_out_error, winner.held_out_error),
                      "held_out_excess_reduction": excess_reduction(before, after)})
    located = [{**o.to_json(), "held_out": False} for o in ident.localisation.objects]
    if ident.held_out_localisation is not None:
        located += [{**o.to_json(), "held_out": True} for o in ident.held_out_localisation.objects]
    forces = [{**f.to_json(), "held_out": False} for f in ident.localisation.forces]
    if ident.held_out_localisation is not None:
        forces += [{**f.to_json(), "held_out": True} for f in ident.held_out_localisation.forces]
    return {
        "format": 1,
        "verdict": ident.verdict,
        "winner": winner.to_json(),
        "runner_up": runner.to_json() if runner is not None else None,
        "margin": round(ident.margin, 3) if math.isfinite(ident.margin) else None,
        "effects": [s.to_json() for s in ident.ranked],
        "candidates": [{"effect": c.effect, "target": c.target, "prior": round(c.prior, 3),
                        "screened_rms_sigma": (round(math.sqrt(c.screened_chi2 / max(1, c.screened_n or none.n)), 3)
                                               if math.isfinite(c.screened_chi2) else None),
                        **({"note": c.note} if c.note else {})} for c in ident.candidates],
        "error": error,
        "located": located,
        "located_force": forces,
        "ranking": {"objects": [[n, float(f"{v:.4g}")] for n, v in ident.localisation.objects_ranked()],
                    "recordings": [[n, float(f"{v:.4g}")] for n, v in ident.localisation.recordings_ranked()]},
        "recordings": {"train": list(ident.train), "held_out": list(ident.held_out)},
        "noise": dict(noise or noise_summary(ident.localisation)),
        "cross_validation": ({"floor": ident.floor, "recordings": len(ident.train) + len(ident.held_out),
                              "cv_gain": CV_GAIN,
                              "stability": ident.stability.to_json() if ident.stability is not None else None,
                              "alike": [a.to_json() for a in ident.alike], "alike_p": ALIKE_P}
                             if ident.floor is not None else None),
        "correlation_time": round(ident.tau, 3),
        "scene_file": scene_file,
        "simulation_failures": dict(failures or {"count": 0, "first": []}),
        "notes": list(ident.notes),
        **loader_json(ident),
        "simulations": int(ident.simulations),
        "rollouts": {k: int(v) for k, v in (ident.rollouts or {"simulated": ident.simulations, "cached": 0}).items()},
        "seconds": round(ident.seconds, 2),
    }


def loader_json(ident: Identification) -> dict[str, Any]:
    """"adjustments": what the loader changed in each recording; "evidence": what that says (a rod that started
    inside the object beyond the noise, the contact gaps: bridge.diagnosis.loader) and where the rod touched the
    outline while it pushed (the recorded frame: bridge.diagnosis.outline)."""
    if ident.loader is None:
        return {"adjustments": [], "evidence": None}
    out = ident.loader.to_json()
    if ident.frame is not None:
        out["evidence"]["frame"] = {**ident.frame.to_json(),
                                    "sentence": ident.frame.sentence() if ident.frame.evident else None}
    if ident.work is not None:
        out["evidence"]["work"] = {**ident.work.to_json(), "sentence": ident.work.sentence()}
    if ident.rod is not None:
        out["evidence"]["rod_friction"] = ident.rod.to_json()
    if ident.support is not None:
        out["evidence"]["support_pressure"] = ident.support.to_json()
    return out


def held_out_rms(s) -> float | None:
    """RMS of the noise-normalised held-out residual (pose and force; 1 = the noise floor)."""
    return math.sqrt(s.held_out_chi2 / s.held_out_n) if s.held_out_chi2 is not None and s.held_out_n else None


def excess_reduction(before: float | None, after: float | None) -> float | None:
    """How much of the residual above the noise floor is gone: 1 - sqrt(after^2 - 1) / sqrt(before^2 - 1) on
    noise-normalised RMS values. Unlike the pose error e, which cannot fall below the measurement noise, it
    reaches 1 when the model explains everything the noise does not; it counts the force sensor too."""
    if before is None or after is None or before <= 1.0:
        return None
    return round(1.0 - math.sqrt(max(after * after - 1.0, 0.0)) / math.sqrt(before * before - 1.0), 4)


def _round4(value: float | None) -> float | None:
    return None if value is None else round(value, 4)


def _reduction(before, after) -> float | None:
    if before is None or after is None or before.e <= 0:
        return None
    return round(1.0 - after.e / before.e, 4)


def noise_summary(loc: Localisation) -> dict[str, float]:
    keys = ("along", "z", "yaw", "tilt")
    out = {}
    for k in keys:
        values = [o.sigma[k] for o in loc.objects if k in o.measured]
        if values:
            out["position" if k == "along" else k] = float(f"{float(np.median(values)):.3g}")
    return out


def parameters_text(s, plus_minus: str = "+-") -> str:
    """A fitted model's own parameters with their 1 sigma and, where it was cross-validated, the range the refits
    without one recording span (`Prediction.spread`): how much the finding hangs on single recordings."""
    spread = s.cv.spread() if s.cv is not None else {}
    return ", ".join(f"{k} = {v:.4g} {plus_minus} {s.std.get(k, math.nan):.2g}"
                     + (f" (refits without one recording: {spread[k][0]:.4g} to {spread[k][1]:.4g})"
                        if k in spread else "") for k, v in s.params.items())


# --- markdown -----------------------------------------------------------------------------------------------
def report_markdown(ident: Identification, data: Mapping[str, Any], figures: Sequence[str]) -> str:
    w, r = ident.winner, ident.runner_up
    lines = ["# Diagnosis", "",
             f"**Verdict: `{ident.verdict}`**" + (f" on `{w.target}`" if ident.verdict != "none" else "")
             + (" (partial)" if ident.partial else ""), ""]
    if ident.partial:
        limit = data.get("time_limit_s")
        lines += [f"**Partial result: the time limit{f' of {limit:g} s' if limit else ''} stopped the search** "
                  "before every candidate was screened and fitted; the verdict is the best of what was tried.", ""]
    if ident.verdict != "none":
        lines += [f"- parameters: {parameters_text(w, '±')}"]
        if w.derived:
            lines += ["- derived: " + ", ".join(f"{k} = {v:.3g}" for k, v in w.derived.items())]
    if ident.stability is not None:
        lines += [f"- stability: {ident.stability.agree} of {len(ident.stability.without)} selections with one "
                  f"recording left out give `{ident.verdict}`" + ("" if ident.stability.stable else " (not stable)")]
    if ident.alike:
        lines += ["- alike: " + ", ".join(f"`{a.effect}` ({100 * a.share:.0f} %, p {a.p:.2f})" for a in ident.alike)
                  + f" predict{'s' if len(ident.alike) == 1 else ''} the recordings not fitted on as well as "
                  f"`{ident.verdict}`: not told apart"]
    if r is not None:
        lines += [f"- runner-up: `{r.effect}` on `{r.target}`; margin {ident.margin:.1f} (log evidence, BIC/2)"]
    lines += [f"- recordings: {len(ident.train)} fitted, {len(ident.held_out)} held out"
              f"; {data['simulations']} simulations ({data['rollouts']['simulated']} run, {data['rollouts']['cached']} from "
              f"the rollout cache) in {ident.seconds:.0f} s"]
    for key in ("time_step", "time_scales", "forks"):
        if data.get(key):
            lines += [f"- {data[key]['note']}"]
    lines += [""]
    for note in ident.notes:
        lines.append(f"> {note}")
    if ident.notes:
        lines.append("")
    e = data["error"]
    lines += ["## Error (the paper's eq. 1-4, c = 0.01)", "", "| | e_t (mm) | e_R (deg) | e |", "|---|---|---|---|"]
    for key, label in (("before", "fitted recordings, before"), ("after", "fitted recordings, after"),
                       ("held_out_before", "held-out, before"), ("held_out_after", "held-out, after")):
        if key in e:
            v = e[key]
            lines.append(f"| {label} | {v['e_t'] * 1e3:.2f} | {math.degrees(v['e_R']):.2f} | {v['e']:.5f} |")
    lines += ["", "## Effects (the verdict first, then by cross-validated prediction)", ""]
    if ident.floor is not None:
        lines += [f"Each recording is predicted by the model fitted without it (cross-validation); an effect must "
                  f"remove at least {100 * CV_GAIN:.0f} % of what the ordinary model (`{ident.floor}`) leaves on "
                  f"those predictions above the noise floor (a geometric mean over the recordings: each weighs "
                  f"alike).", ""]
    lines += ["| effect | target | score | k | rms/sigma | cross-validated rms/sigma | change of the floor's excess | "
              "held-out e | parameters |", "|---|---|---|---|---|---|---|---|---|"]
    for s in ident.ranked:
        held = f"{s.held_out_error.e:.5f}" if s.held_out_error is not None else "-"
        params = ", ".join(f"{k} = {v:.4g}" for k, v in s.params.items())
        cv = f"{math.sqrt(s.cv.chi2 / s.cv.n):.2f}" if s.cv is not None and s.cv.n else "-"
        share = f"{-100 * s.cv_share:+.0f} %" if s.cv_share is not None else "-"
        lines.append(f"| {s.effect} | {s.target} | {s.score:.1f} | {s.k} | {s.rms:.2f} | {cv} | {share} | {held} | "
                     f"{params} |")
    lines += ["", "## Where the mismatch is", "", "```", ident.localisation.text(), "```", ""]
    lines += loader_markdown(data)
    noise = data["noise"]
    lines += ["Noise floor estimated from the observations: " +
              ", ".join(f"{k} {v:.3g}" for k, v in noise.items()) + " (m, rad).", ""]
    for f in figures:
        lines.append(f"![{Path(f).stem}]({Path(f).name})")
    return "\n".join(lines) + "\n"


def loader_markdown(data: Mapping[str, Any]) -> list[str]:
    """The report's "What the loader changed" section: every recording the loader repaired, and how."""
    rows = []
    for entry in data.get("adjustments") or ():
        for a in entry["adjustments"]:
            if a["kind"] == "start_clearance" and (a["shift_m"] != [0.0, 0.0] or a.get("inside")):
                what = (f"rod started {a['penetration_m'] * 1e3:.2f} mm inside (threshold "
                        f"{a.get('threshold_m', float('nan')) * 1e3:.2f} mm); tip track moved x "
                        f"{a['shift_m'][0] * 1e3:+.2f} mm, y {a['shift_m'][1] * 1e3:+.2f} mm")
            elif a["kind"] == "dropped_rows":
                what = f"{a['count']} {a['stream']} row(s) dropped (clock jitter)"
            elif a["kind"] == "frame_yaw":
                what = f"mesh frame turned {math.degrees(a['yaw_rad']):+.1f} deg from the pose frame"
            else:
                continue
            rows.append(f"| {entry['recording']} | {a['kind']} | {what} |")
    evidence = (data.get("evidence") or {}).get("start_inside") or {}
    read = [((data.get("evidence") or {}).get(key) or {}).get("sentence")
            for key in ("frame", "work", "rod_friction", "support_pressure")]
    sentences = ([evidence["sentence"]] if evidence.get("sentence") else []) + \
        list(((data.get("evidence") or {}).get("contact") or {}).get("sentences") or ()) + [s for s in read if s]
    if not rows and not sentences:
        return []
    lines = ["## What the loader changed, and what the recordings say before any simulation", ""]
    for sentence in sentences:
        lines += [f"**{sentence[0].upper()}{sentence[1:]}.**", ""]
    return lines + (["| recording | adjustment | what |", "|---|---|---|", *rows, ""] if rows else [])


# --- plots ------------------------------------------------------------------------------------------------------
def plot_residuals(located: LocatedObject, after: LocatedObject | None, path: Path | BinaryIO) -> Path | BinaryIO:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    t = located.times
    for key, style in (("along", "C0"), ("across", "C1")):
        axes[0].plot(t, located.components[key] * 1e3, style, label=f"{key}")
        if after is not None:
            axes[0].plot(after.times, after.components[key] * 1e3, style, ls="--", lw=1, label=f"{key} (after)")
    for key, style in (("yaw", "C2"), ("tilt", "C3")):
        if key in located.measured:
            axes[1].plot(t, np.degrees(located.components[key]), style, label=key)
            if after is not None:
                axes[1].plot(after.times, np.degrees(after.components[key]), style, ls="--", lw=1,
                             label=f"{key} (after)")
    noise = located.sigma["along"] * 1e3
    axes[0].axhspan(-3 * noise, 3 * noise, color="0.85", label="3 sigma noise")
    for ax in axes:
        if located.onset_s is not None:
            ax.axvline(located.onset_s, color="k", ls=":", lw=1)
        if located.push_s is not None:
            ax.axvspan(*located.push_s, color="C4", alpha=0.08)
    name = located.recording if len(located.recording) <= 40 else "..." + located.recording[-37:]
    title = f"{name} / {located.object}"
    if located.contact:
        title += f": onset {located.onset_s:.2f} s after {' - '.join(located.contact)}"
    axes[0].set_title(title, fontsize=9)
    axes[0].set_ylabel("observed - simulated (mm)")
    axes[1].set_ylabel("deg")
    axes[1].set_xlabel("t (s)")
    axes[0].legend(fontsize=7, ncol=3)
    axes[1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
    return path


def plot_paths(before: Localisation, after: Localisation | None, path: Path | BinaryIO) -> Path | BinaryIO:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    objs = list(before.objects)
    n = len(objs)
    cols = min(4, max(1, n))
    rows = int(math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.0 * rows), squeeze=False)
    after_by = {(o.recording, o.object): o for o in (after.objects if after else ())}
    for ax, o in zip(axes.ravel(), objs):
        ax.plot(o.obs_xy[:, 0] * 1e3, o.obs_xy[:, 1] * 1e3, "k.", ms=2, label="observed")
        ax.plot(o.sim_xy[:, 0] * 1e3, o.sim_xy[:, 1] * 1e3, "C3", lw=1, label="simulated")
        a = after_by.get((o.recording, o.object))
        if a is not None:
            ax.plot(a.sim_xy[:, 0] * 1e3, a.sim_xy[:, 1] * 1e3, "C0", lw=1, label="with the effect")
        ax.set_title(o.recording[-30:], fontsize=7)
        ax.set_aspect("equal", adjustable="datalim")
        ax.tick_params(labelsize=7)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=6)
    fig.suptitle("object centre paths (mm)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
    return path


def plot_scores(ident: Identification, path: Path | BinaryIO) -> Path | BinaryIO:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ranked = list(ident.ranked)
    fig, ax = plt.subplots(figsize=(6, 0.4 * len(ranked) + 1))
    labels = [f"{s.effect} ({s.target})" for s in ranked]
    scores = [max(s.score, 0.0) for s in ranked]
    colors = ["C2" if s.effect == ident.verdict else "C7" for s in ranked]
    ax.barh(labels[::-1], np.log10(1.0 + np.array(scores[::-1])), color=colors[::-1])
    ax.set_xlabel("log10(1 + score), score = log evidence against none")
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
    return path


def write_outputs(out: Path, data: Mapping[str, Any], markdown: str,
                  others: Mapping[Path, Content] | None = None) -> tuple[Path, Path]:
    """diagnosis.json and report.md, published as one set with `others` (the scene file, plots; None removes a
    stale one): an interrupt leaves the old report or the new one."""
    j, m = out / "diagnosis.json", out / "report.md"
    write_set({**(others or {}), j: json.dumps(data, indent=2) + "\n", m: markdown})
    return j, m


def validate(data: Mapping[str, Any]) -> None:
    """Raise jsonschema.ValidationError when `data` does not follow diagnosis.schema.json."""
    import jsonschema

    jsonschema.validate(data, load_schema())
