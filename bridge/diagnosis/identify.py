"""Identify the missing physics: fit candidate effects and choose the one that predicts recordings it was not
fitted on better than the ordinary parameters do.

Recipe (`identify`):
1. locate the mismatch with the world model as it is (`locate`); if no recording carries a residual above the
   noise floor, the verdict is `none` and nothing is fitted; read what the loader's evidence says before any
   simulation (a rod offset from the contact gaps, rods that started inside the object) and where the rod touched
   the outline while it pushed (the recorded frame on the object, `outline`);
2. fit the ordinary parameters first: the friction coefficients of the object carrying most of the residual and
   of the surface it slides on, with its contact's stiffness and damping (the `friction` model);
3. screen every other effect of the catalog, each together with the friction coefficients, likely ones first
   (their signature against the localisation), from the fitted coefficients: one Gauss-Newton step from the
   effect's null values for smooth effects, the seeds the evidence suggests for the others (an obstacle where the
   rod jammed, a region where the residual began), with the friction coefficients stepped to suit the seed;
4. fit the best screened candidates fully with the friction coefficients (Levenberg-Marquardt);
5. cross-validate (`crossval`): every model worth its parameters predicts each recording it was not fitted on;
   the floor is the form of the friction model that predicts best: fitted, fitted at the database's contact, or
   with the sliding coefficient held at what the work the robot did reads (`_read_friction`, a measurement);
6. the verdict: the effect that predicts best among those that remove at least CV_GAIN of what the ordinary model
   leaves (a geometric mean over the recordings) and agree with the evidence;
   else the ordinary model (`friction`, where its coefficients moved beyond their negligible size: the contact's
   stiffness and damping are no finding; else `none`); with the contact fitted (`Options.contact`, the default),
   a verdict's effect screened at the friction model's contact is refitted at the database's and kept there
   unless the fitted contact earns CV_GAIN. Report winner, runner-up, margin, parameters and their uncertainty
   (curvature).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Sequence

import numpy as np

from ..errors import DiagnosisError
from ..params import Model, Parameter, ParameterSet, Setting
from ..params.kinds import NEGLIGIBLE_FRICTION, kind_named, link_friction
from ..params.surfaces import support_of
from ..rollout.compare import PoseError
from ..timelimit import STOPPED, TimeLimit
from .effects import EFFECTS, Evidence, get_effect
from .effects.base import Effect, pname
from .cone import RodReading, contact_friction, rod_reading
from .crossval import ALIKE_P, Prediction, Stability, predict_left_out, prediction
from .effects.object_scale import outline_radius
from .loader import NEGLIGIBLE, NOISE_SIGMAS, ContactFit, LoaderEvidence, read_adjustments
from .locate import Localisation, locate
from .outline import FrameFit, frame_evidence
from .pressure import NEGLECTED, SupportReading, calibrated_reading, recorded_torsions
from .runs import Run, Runner, chi2_of
from .search import Evaluator, FitResult, bic, correlation_time, differenced, fit, pose_error_of, screen
from .work import WorkFit, work_fit

MAX_FULL_FITS = 4  # candidates fitted fully after screening
NOISE_RMS = 1.5  # a model whose normalised RMS is below this sits at the noise floor
MIN_GAIN = 0.2  # share of the simpler model's excess chi^2 that extra parameters must remove
NEAR_NOISE_GAIN = 0.5  # the same when the simpler model is within NOISE_RMS of the noise floor: what is left there
#                        is as likely the start poses' error (read from noisy observations) as missing physics
# the contact's own parameters, fitted with the friction pairs as the ordinary model when asked (`Options.contact`):
# every world differs from the model's contact a little (stiffness, damping, the solver's step, the servo that
# holds the rod), and an effect fitted without them is credited with that difference (a clean mismatched hex, its
# contact twice as stiff at a 4 ms step, was called `mass` at 0.75 kg for 0.90: the lighter block took up the
# stiffer contact). Effects are fitted with it held where the friction model put it or at the database's
# (`_held_contact`); it is no finding: the verdict `friction` needs the coefficients themselves to move
# (`_coefficients_negligible`; docs/diagnosis.md section 3, step 2)
CONTACT = ("hydroelastic_modulus", "dissipation")
CV_GAIN = 0.25  # share of the ordinary model's cross-validated chi^2 above the noise an effect must remove
#               (`Prediction.compare`: a geometric mean over the recordings)
UNEXPLAINED = 3.0  # cross-validated RMS (noise floors) above which the report says the verdict explains little
FIRST_CONTACT = 0.1  # share of a push within which a residual that starts counts as starting at the first contact
FRAME_FLOOR = (0.001, math.radians(1.0))  # m, rad: the least uncertainty granted to the frame the pushing samples
#                                            imply (an outline modelled to a millimetre and a degree)
SIZE_SPREAD = 0.5  # share of a fitted size's move of the outline granted to the gaps' reading of it: where the
#                    rod meets the outline, its distance from the centre differs from `outline_radius` by up to
#                    that (10-25 % on the dataset's convex shapes, 50 % on the non-convex butter)
MIN_FOLDS = 3  # recordings cross-validated for the verdict's stability to be read (`_stability`)
FRICTION_EXTRA = 4  # more iterations for the friction fit: every other model is judged against it
SCREENED = 0.5  # share of the training recordings a screen replays (at least MIN_SCREENED; `_screening`)
MIN_SCREENED = 3


@dataclass(frozen=True)
class Options:
    effects: tuple[str, ...] | None = None  # restrict the catalog (None: all)
    max_full_fits: int = MAX_FULL_FITS
    max_iterations: int = 6  # per fit: solver evaluations (lm) or generations (es, cmaes)
    optimizer: str = "lm"  # of the full fits (bridge.optim.NAMES); screening always takes one Gauss-Newton step
    contact: bool = True  # the object's contact stiffness and damping among the ordinary parameters (`CONTACT`)

    def __post_init__(self) -> None:
        """An unknown effect would be ignored, and the diagnosis would answer another question than asked."""
        for name in self.effects or ():
            if name not in EFFECTS:
                raise DiagnosisError(f"unknown effect {name!r}; effects: {', '.join(EFFECTS)}", field="effects")


@dataclass(frozen=True, eq=False)
class Candidate:
    effect: str
    target: str
    prior: float
    screened_chi2: float = math.inf
    start: dict[str, float] = field(default_factory=dict)  # the screened point, by parameter name
    note: str = ""
    database_contact: bool = False  # screened (and so fitted) with the database's contact (`_held_contact`)
    screened_n: int = 0  # the samples `screened_chi2` is over (the recordings screened, `_screening`) ...
    screened_floor: float = math.inf  # ... and the least chi^2 of `none` and the friction model over them


@dataclass(frozen=True, eq=False)
class Scored:
    """A fitted model: the effect named, the whole model (ordinary parameters + effect), its evidence."""

    effect: str
    target: str
    params: dict[str, float]
    std: dict[str, float]
    model: Model
    k: int
    chi2: float
    n: int
    bic: float = math.nan
    score: float = math.nan  # (BIC_none - BIC) / 2: log evidence against `none`
    error: PoseError | None = None
    held_out_chi2: float | None = None
    held_out_n: int | None = None
    held_out_runs: tuple[Run, ...] = ()  # the model fitted on the others, on each held-out recording
    held_out_error: PoseError | None = None
    derived: dict[str, float] = field(default_factory=dict)
    evaluations: int = 0
    model_std: dict[str, float] = field(default_factory=dict)  # 1 sigma of every fitted parameter of the model
    at_bound: dict[str, float] = field(default_factory=dict)  # fitted parameters a bound stopped: the bound
    cv: Prediction | None = None  # every recording predicted by the model fitted without it (`crossval`)
    cv_share: float | None = None  # of the floor's cross-validated excess chi^2, the share this model removes
    contradicted: str | None = None  # why direct evidence (the loader's, before any simulation) rules it out
    measured: bool = False  # its own parameters held at what the recordings measure before any simulation

    @property
    def rms(self) -> float:
        return math.sqrt(self.chi2 / self.n) if self.n else 0.0

    def to_json(self) -> dict[str, Any]:
        out = {"effect": self.effect, "target": self.target,
               "params": {k: float(f"{v:.6g}") for k, v in self.params.items()},
               "std": {k: (float(f"{v:.3g}") if math.isfinite(v) else None) for k, v in self.std.items()},
               "score": round(self.score, 3), "bic": round(self.bic, 3), "k": self.k,
               "rms_sigma": round(self.rms, 3),
               "model": [{"kind": m.kind, "target": m.target, "value": float(f"{m.value:.6g}"),
                          **({"effect": m.effect} if m.effect else {})} for m in self.model]}
        if self.error is not None:
            out["error"] = _error_json(self.error)
        if self.held_out_error is not None:
            out["held_out_error"] = _error_json(self.held_out_error)
        if self.held_out_chi2 is not None and self.held_out_n:
            out["held_out_rms_sigma"] = round(math.sqrt(self.held_out_chi2 / self.held_out_n), 3)
        if self.derived:
            out["derived"] = {k: float(f"{v:.4g}") for k, v in self.derived.items()}
        if self.measured:
            out["measured"] = True
        if self.at_bound:
            out["at_bound"] = {k: float(f"{v:.6g}") for k, v in self.at_bound.items()}
        if self.cv is not None and self.cv.n:
            out["cv"] = {"rms_sigma": round(math.sqrt(self.cv.chi2 / self.cv.n), 3), "recordings": len(self.cv.each),
                         "excess_reduction": round(self.cv_share, 4) if self.cv_share is not None else None,
                         "rms_sigma_each": {k: round(math.sqrt(c / n), 3) if n else None
                                            for k, (c, n) in self.cv.each.items()}}
            spread = self.cv.spread()
            if spread:
                out["cv"]["params_range"] = {k: [float(f"{lo:.6g}"), float(f"{hi:.6g}")]
                                             for k, (lo, hi) in spread.items()}
        return out


@dataclass(frozen=True, eq=False)
class Identification:
    verdict: str
    ranked: tuple[Scored, ...]  # best first; `none` included
    localisation: Localisation
    train: tuple[str, ...]
    held_out: tuple[str, ...]
    tau: float
    candidates: tuple[Candidate, ...]
    notes: tuple[str, ...]
    simulations: int
    seconds: float
    held_out_localisation: Localisation | None = None
    stopped: str | None = None  # "time limit": the search was cut short, the verdict is over what was tried
    loader: LoaderEvidence | None = None  # what the loader changed in each recording, read as evidence
    rollouts: dict[str, int] = field(default_factory=dict)  # {simulated, cached}: of `simulations`, run and cached
    floor: str | None = None  # the ordinary model every effect was cross-validated against (None: no cross-validation)
    frame: FrameFit | None = None  # the recorded frame the pushing samples imply (`outline`), before any simulation
    work: WorkFit | None = None  # the friction and slope the work the robot did implies (`work`), before any simulation
    stability: Stability | None = None  # the verdict with each recording left out of the cross-validation
    rod: RodReading | None = None  # the rod's friction the force's direction reads, against the friction model's
    support: SupportReading | None = None  # the footprint scale the force and the twist read, against the verdict's
    alike: tuple["Alike", ...] = ()  # accepted effects the recordings do not tell apart from the verdict (`_alike`)

    @property
    def partial(self) -> bool:
        return self.stopped is not None

    @property
    def winner(self) -> Scored:
        return next(s for s in self.ranked if s.effect == self.verdict)

    @property
    def runner_up(self) -> Scored | None:
        others = [s for s in self.ranked if s.effect != self.verdict]
        return others[0] if others else None

    @property
    def margin(self) -> float:
        r = self.runner_up
        return self.winner.score - r.score if r is not None else math.inf

    def model(self) -> Model:
        return self.winner.model


def _error_json(e: PoseError) -> dict[str, float]:
    return {"e_t": float(f"{e.e_t:.5g}"), "e_R": float(f"{e.e_R:.5g}"), "e": float(f"{e.e:.5g}"), "count": e.count}


# --- the recipe -----------------------------------------------------------------------------------------------
def identify(runner: Runner, train: Sequence[int], held_out: Sequence[int] = (), options: Options = Options(),
             log=None, progress=None, limit: TimeLimit | None = None) -> Identification:
    """The recipe above. `log(message)` gets a line per step, `progress(done, total)` the steps done (locate, the
    friction fit, each screen, each full fit). `limit` (a `TimeLimit`): once it has passed, no further
    candidate is screened or fitted, the fit under way ends at its best point so far, and the verdict is taken
    over what was tried (`stopped`, and a note saying so)."""
    started = time.perf_counter()
    sims0 = runner.simulations
    rollouts0 = runner.rollouts()

    def rollouts() -> dict[str, int]:
        now = runner.rollouts()
        return {k: now[k] - rollouts0[k] for k in now}
    say = log or (lambda message: None)
    limit = limit or TimeLimit()
    step = [0, None]

    def advance(total: int | None = None) -> None:
        step[0] += 1
        if total is not None:
            step[1] = total
        if progress is not None:
            progress(step[0], step[1])

    if not train:
        raise DiagnosisError("identify needs at least one training recording")
    ev = Evaluator(runner, train)
    loc = locate(runner, list(train))
    held_loc = locate(runner, list(held_out)) if held_out else None
    world = runner.prepared[train[0]].world
    odb = runner.odb
    notes: list[str] = []
    ev.cache[()] = tuple(loc.runs)
    none_chi2, n = chi2_of(loc.runs)
    # what the loader changed, as evidence: a rod that started inside the object is a calibration offset's mark
    order = list(train) + list(held_out)
    loader = read_adjustments([runner.prepared[i] for i in order], range(len(train), len(order)))
    for sentence in loader.sentences():
        notes.append(sentence)
        say(sentence)
    ranked_objects = [name for name, excess in loc.objects_ranked() if excess > 0] or \
        [o for o, _ in loc.objects_ranked()]
    # where the rod touched the outline while it pushed (the fitted recordings): the recorded frame on the object
    frame = frame_evidence([runner.prepared[i] for i in train], odb, ranked_objects[0])
    if frame is not None and frame.evident:
        notes.append(frame.sentence() + "; object_frame is held at this frame, only the friction fitted with it")
        say(notes[-1])
    gaps = loader.contact_fit()
    measured = _measured(loader, world)
    held = {**measured, **_held_frame(frame)}  # what the fits hold; only `measured` is evidence by itself
    # the work the robot did on the object: the friction it slid against and the slope it climbed (a seed)
    work = work_fit([runner.prepared[i].trial for i in train], odb, ranked_objects[0])
    if work is not None:
        notes.append(work.sentence())
        say(notes[-1])
    evidence = Evidence(tuple(dict(o.features) for o in loc.objects if o.object == ranked_objects[0]), world, odb,
                        loc.force_scale(), len(loader.inside) / max(1, len(loader.readings)),
                        loader.offset_estimate(), loader.offset_evident,
                        frame.values() if frame is not None and frame.evident else None,
                        gaps.inflation if gaps is not None and gaps.inflation_evident else None,
                        gaps.latency if gaps is not None and gaps.latency_evident else None,
                        work.seed if work is not None else None)
    none = Scored("none", "world", {}, {}, (), 0, none_chi2, n, error=pose_error_of(loc.runs))
    say(f"nominal: rms {none.rms:.1f} sigma over {len(train)} recording(s); "
        f"{sum(o.significant for o in loc.objects)} (recording, object) pair(s) above the noise floor"
        + (f"; the robot's force {loc.force_scale():.2f}x the simulated one, above the noise in "
           f"{sum(f.significant for f in loc.forces)} of {len(loc.forces)} recording(s)"
           if loc.force_scale() is not None else ""))
    if not loc.any_significant:
        advance(1)
        notes.append("no recording carries a residual above the noise floor: nothing to fit")
        scored = _score([none], 1.0)
        scored = _held_out(runner, held_out, scored)
        return Identification("none", tuple(scored), loc, _names(runner, train), _names(runner, held_out), 1.0, (),
                              tuple(notes), runner.simulations - sims0, time.perf_counter() - started, held_loc,
                              loader=loader, rollouts=rollouts(), frame=frame, work=work)

    allowed = set(options.effects or EFFECTS) - {"none"}
    focus = ranked_objects[:1]
    # the candidates of step 3 (each effect on each target it may apply to), likely ones first
    candidates = []
    for name in EFFECTS:
        if name in ("none", "friction") or name not in allowed:
            continue
        effect = get_effect(name)
        for target in effect.targets(world, odb, focus):
            candidates.append(Candidate(name, target, float(effect.signature(evidence, target))))
    candidates.sort(key=lambda c: -c.prior)
    advance(2 + len(candidates) + min(options.max_full_fits, len(candidates)))
    # 2. the ordinary parameters: the friction of the object carrying the residual, as the coefficients of its two
    #    pairs (with the surface it slides on, with the robot's links), which the physics has independent
    #    (`kinds.PairFriction`); the object's own coefficient where it has neither
    friction_params = _friction_parameters(world, odb, focus[0], options.contact)
    base_space = ParameterSet(tuple(friction_params), "the ordinary parameters")
    # its Jacobian at the optimum is differenced: the screens below start there, and a candidate at its null
    # values is this model (`Evaluator.canonical`), so their Jacobians' friction columns are these
    base_fit = fit(ev, base_space, np.zeros(base_space.dim), max_iterations=options.max_iterations + FRICTION_EXTRA,
                   optimizer=options.optimizer, should_stop=limit.expired, final_jacobian=True)
    friction_scored = _from_fit("friction", None, base_fit, world, odb)
    fits = {("friction", None): base_fit}  # the fit of each model, by (effect, target): its Jacobian for the winner
    say(f"friction: {_fmt(base_fit.values())}, rms {friction_scored.rms:.1f}"
        + (" (cut short by the time limit)" if base_fit.stopped else "") + f" [{runner.simulations} simulations]")
    rod, support = _force_readings(runner, train, friction_scored.model, focus[0])
    if rod is not None:
        notes.append(rod.sentence())
        say(notes[-1])
    if support is not None:  # the report's evidence says it against the verdict's footprint (`_against_verdict`)
        say(support.sentence())
    advance()

    # 3. screen candidates (each together with the friction coefficients), likely ones first, on the recordings the
    #    friction model leaves the most to explain
    sev = _screening(ev, base_fit.model())
    screened = []
    fitted_friction = base_fit.values()  # every candidate starts from the fitted coefficients
    effect_friction = _held_contact(friction_params, fitted_friction)
    free_friction = sum(p.free for p in effect_friction)  # they lead the space, as in the friction model's
    nominal_friction = {p.name: p.start for p in friction_params}
    database_friction = _held_contact(friction_params, nominal_friction)
    frictions = [(fitted_friction, base_fit.x[:free_friction]), (nominal_friction, None)]
    measured_friction = _work_friction(work, friction_params, fitted_friction)
    if measured_friction is not None:
        say(f"the screens seeded by the work also start from the sliding coefficient the robot's force measures "
            f"({work.coefficient:.3f} +- {work.coefficient_sd:.3f}; the friction fit's contradicts it)")
    for k, c in enumerate(candidates):
        if limit.expired():
            screened += [Candidate(r.effect, r.target, r.prior, math.inf, {}, "not screened: time limit")
                         for r in candidates[k:]]
            break
        effect = get_effect(c.effect)
        space = _space(effect_friction, effect, c.target, world, odb, held)
        # each seed with each start of the friction coefficients (`_friction_starts`); smooth effects then take
        # one Gauss-Newton step from the best start of each
        starts = [_with_friction(space.to_normal({**values, **seed}), x_f)
                  for seed in effect.seeds(evidence, c.target)
                  for values, x_f in _friction_starts(effect, frictions, measured_friction)]
        if not starts:
            screened.append(Candidate(c.effect, c.target, c.prior, math.inf, {}, "no seed from the localisation"))
            continue
        # a local effect (a patch, a post) changes only the pushes that reach it, which need not be those the
        # floor fits worst: screened on every recording
        cev = ev if effect.local else sev
        x, chi2 = _best_start(cev, space, starts)  # one batch on the workers
        ordinary = effect_friction
        if any(p.kind.contact_model for p in friction_params):  # the same point at the database's contact
            at_database = _chi2_below(cev, _model(_space(database_friction, effect, c.target, world, odb, held), x),
                                      chi2)
            if at_database < chi2:
                ordinary, chi2 = database_friction, at_database
        region = effect.fit_region(space.as_dict(space.from_normal(x)), c.target)
        space = _space(ordinary, effect, c.target, world, odb, held, region)
        # from the best start, one step in every coordinate; for an effect without a useful gradient at its null
        # (a post, a mass) also one with only the friction coefficients moved to suit the seed (a heavier object
        # pushes back harder with less friction)
        frees = [None] + ([range(free_friction)] if free_friction and not effect.smooth else [])
        for free in frees:
            y, c2 = screen(cev, space, x, free=free)
            if c2 < chi2:
                x, chi2 = y, c2
        screen_floor, screen_n = min(cev.chi2(()), cev.chi2(base_fit.model())), chi2_of(cev.runs(()))[1]
        screened.append(Candidate(c.effect, c.target, c.prior, chi2, space.as_dict(space.from_normal(x)),
                                  database_contact=ordinary is database_friction, screened_n=screen_n,
                                  screened_floor=screen_floor))
        say(f"screen {c.effect} ({c.target}" + (", the database's contact" if ordinary is database_friction else "")
            + f"): prior {c.prior:.2f}, rms {math.sqrt(chi2 / screen_n):.1f} over {len(cev.indices)} recording(s) "
            f"[{runner.simulations} simulations]")
        advance()

    reference = min(none_chi2, base_fit.chi2)

    def rank_key(c: Candidate) -> float:
        # the chi^2 the screen removed where it was screened, a share of the floor's over every recording (a
        # candidate screened on some is taken to change nothing on the others); < 0: the screen made it worse
        gain = (c.screened_floor - c.screened_chi2) / max(reference, 1e-12)
        return -(gain * (0.5 + 0.5 * c.prior))

    order = sorted([c for c in screened if math.isfinite(c.screened_chi2)], key=rank_key)
    full = _full_fits(order, options.max_full_fits, lambda c: _all_measured(c, world, odb, held))
    step[1] = step[0] + len(full)  # what is left: the full fits
    # 4. full fits, each effect together with the friction coefficients, from the screened point
    fitted: list[Scored] = _held_out(runner, held_out, [none, friction_scored])
    # every one of the best `max_full_fits`: a single Gauss-Newton step is a rough screen (an off-centre weight in
    # a tall box screened at no gain and fitted to half the residual of the screen's favourite)
    fits_done = 0
    for c in full:
        if limit.expired():
            break
        effect = get_effect(c.effect)
        space = _space(database_friction if c.database_contact else effect_friction, effect, c.target, world, odb,
                       held, effect.fit_region(c.start, c.target))
        # start from the screened point, or from the fitted friction with the screened effect if that is better
        starts = [space.to_normal(c.start), space.to_normal({**c.start, **base_fit.values()})]
        result, scored = _fit_effect(runner, ev, space, starts, c.effect, c.target, held_out, options, limit,
                                     _all_measured(c, world, odb, measured))
        # a refit from a nesting effect's fit (`_nested`) replaces the earlier fit only where it fits better
        before = next((k for k, f in enumerate(fitted) if (f.effect, f.target) == (c.effect, c.target)), None)
        better = before is None or scored.chi2 < fitted[before].chi2
        if better:
            fits[(c.effect, c.target)] = result
        frictions = {s.name: s.value for s in scored.model if s.effect == "friction"}
        # a fair comparison: if the effect's fit found better friction coefficients than the friction fit did,
        # the friction model gets them too (refitted from there), so the effect is not credited with them
        x_f = base_space.to_normal(frictions)
        if _chi2_below(ev, _model(base_space, x_f), fits[("friction", None)].chi2) < fits[("friction", None)].chi2:
            base_fit = fit(ev, base_space, x_f, max_iterations=FRICTION_EXTRA, optimizer=options.optimizer,
                           should_stop=limit.expired)
            fitted[1] = _held_out(runner, held_out, [_from_fit("friction", None, base_fit, world, odb)])[0]
            fits[("friction", None)] = base_fit
            effect_friction = _held_contact(friction_params, base_fit.values())  # the later effects' contact
            say(f"friction refitted from {c.effect}'s coefficients: {_fmt(base_fit.values())}, "
                f"rms {fitted[1].rms:.1f}")
        if before is None:
            fitted.append(scored)
        elif better:
            fitted[before] = scored
        ok = _fit_reason(scored, fitted[0], fitted[1], world, odb) is None
        say(f"fit {c.effect} ({c.target}): {_fmt(scored.params)}, rms {scored.rms:.1f} (friction {_fmt(frictions)})"
            f"{'' if ok else ' - not confirmed'}" + (" (cut short by the time limit)" if result.stopped else "")
            + f" [{runner.simulations} simulations]")
        fits_done += 1
        advance()
        inner = _nested(c, scored, order, fits, world, odb)
        if inner is not None:  # fitted in this loop from `c`'s fit, in place of its screened point if pending
            here = full.index(c)
            pending = next((k for k in range(here + 1, len(full))
                            if (full[k].effect, full[k].target) == (inner.effect, inner.target)), None)
            if pending is None:
                full.append(inner)
                step[1] += 1
            else:
                full[pending] = inner
            say(f"{c.effect}'s own parameters are negligible: {inner.effect} is fitted from its fit")
    stopped = STOPPED if limit.stopped_after is not None else None
    if stopped:
        tried = sum(1 for c in screened if c.note != "not screened: time limit")
        notes.append(f"partial: {limit.text()} stopped the search after screening {tried} of {len(candidates)} "
                     f"candidate(s) and fitting {fits_done} fully (of up to "
                     f"{min(options.max_full_fits, len(candidates))}); the verdict is over what was tried, an effect "
                     "not tried may explain more")
        say(notes[-1])
    # the ordinary model at the database's contact as well: the floor is whichever of the two predicts the
    # recordings it was not fitted on better, so that no effect fitted at the database's contact is credited with
    # the contact (`_cross_validate`)
    other = None
    contact = {p.name: float(p.start) for p in friction_params if p.kind.contact_model}
    fitted_contact = fits[("friction", None)].values()
    if contact and any(not math.isclose(fitted_contact[k], v) for k, v in contact.items()) and not limit.expired():
        at_database = ParameterSet(tuple(database_friction), "the ordinary parameters at the database's contact")
        result = fit(ev, at_database, at_database.to_normal(fits[("friction", None)].values()),
                     max_iterations=options.max_iterations + FRICTION_EXTRA, optimizer=options.optimizer,
                     should_stop=limit.expired)
        other = (_held_out(runner, held_out, [_from_fit("friction", None, result, world, odb)])[0], result)
        say(f"friction at the database's contact: {_fmt(result.values())}, rms {other[0].rms:.1f} "
            f"[{runner.simulations} simulations]")
    read = [] if limit.expired() else _read_friction(ev, work, friction_params, fits[("friction", None)].values(),
                                                       world, odb)
    read = list(zip(_held_out(runner, held_out, [s for s, _ in read]), [r for _, r in read]))  # one batch
    for (s, r), where in zip(read, ("the database's", "the friction fit's")):
        say(f"friction as the work reads it: {_fmt(s.params)} (the rod's pair and the contact {where}), rms "
            f"{s.rms:.1f} [{runner.simulations} simulations]")
    fitted = [_checked_against(s, loader, frame, world, odb) for s in fitted]
    tau = correlation_time(ev.runs(min(fitted, key=lambda s: s.chi2).model))
    scored = _score(fitted, tau)
    # the other variants of the friction model, scored against `none` (fitted[0]) as the rest were
    variants = [(next(m for m in _score([fitted[0], v[0]], tau) if m.effect == "friction"), v[1])
                for v in (other, *read) if v is not None]
    scored, fits = _cross_validate(runner, ev, scored, fits, loc, _names(runner, held_out), world, odb, variants)
    floor_fit = fits[("friction", None)]
    if any(floor_fit is r for _, r in read):
        say("the floor is the friction the work reads: it predicts the recordings it was not fitted on better than "
            "the fitted coefficients")
    elif other is not None and not any(p.free and p.kind.contact_model for p in floor_fit.space.entries):
        say("the floor is the friction model at the database's contact: it predicts the recordings it was not "
            "fitted on better than with the contact fitted")
    scored = [_with_uncertainty(s, fits[_fit_key(s)], tau) if _fit_key(s) in fits else s for s in scored]
    say(f"cross-validated {sum(s.cv is not None for s in scored)} model(s) [{runner.simulations} simulations]")
    verdict, check, floor = _verdict(scored, world, odb)
    winner = next(s for s in scored if s.effect == verdict)
    contact = _database_contact(fits[_fit_key(winner)].space, friction_params) \
        if verdict not in ("none", "friction") and winner.cv is not None and floor.cv is not None else None
    if contact is not None and not limit.expired():
        # 6. the verdict's effect, screened at the friction model's contact, refitted at the database's and kept
        #    there unless the fitted contact earns its place on the recordings it was not fitted on: step 3 chose
        #    by the fit alone, and the held contact was fitted on every recording the cross-validation leaves out
        effect = get_effect(verdict)
        start = next(c.start for c in screened if (c.effect, c.target) == (verdict, winner.target))
        space = _space(contact, effect, winner.target, world, odb, held, effect.fit_region(start, winner.target))
        result, variant = _fit_effect(runner, ev, space, [space.to_normal(fits[_fit_key(winner)].values())],
                                      verdict, winner.target, held_out, options, limit, winner.measured)
        none = next(s for s in scored if s.effect == "none")
        variant = _score([none, _checked_against(variant, loader, frame, world, odb)], tau)
        variant, refitted = _validated(runner, ev, next(s for s in variant if s.effect == verdict),
                                       {**fits, _fit_key(winner): result}, loc)
        accepted = _acceptable(variant, none, floor if floor.effect == "friction" else None, world, odb) is None
        # the contact is no finding: it must earn its place as any fitted parameter does
        earned = winner.cv.compare(variant.cv)
        better = accepted and earned < CV_GAIN
        say(f"{verdict} refitted at the database's contact: {_fmt(variant.params)}, rms {variant.rms:.1f}; on "
            f"recordings it was not fitted on it removes {100 * variant.cv.compare(floor.cv):.0f} % of what "
            f"{floor.effect} leaves ({100 * winner.cv.compare(floor.cv):.0f} % at the friction model's contact, "
            f"which removes {100 * earned:.0f} % of what the database's leaves, {100 * CV_GAIN:.0f} % to earn it): "
            + ("taken" if better else "kept at the friction model's" + ("" if accepted else " (not accepted there)"))
            + f" [{runner.simulations} simulations]")
        if better:
            notes.append(f"{verdict} is fitted at the database's contact: the friction model's predicts the "
                         f"recordings it was not fitted on no better by {100 * CV_GAIN:.0f} %")
            fits = refitted
            scored = [_with_uncertainty(variant, fits[_fit_key(variant)], tau) if s is winner else s for s in scored]
            verdict, check, floor = _verdict(scored, world, odb)
    if check:
        notes.append(check)
    stability = _stability(scored, verdict, world, odb)
    if stability is not None:
        notes.append(stability.sentence())
        say(notes[-1])
    alike = _alike(scored, verdict, world, odb)
    scored = _rank(scored, verdict, floor)
    if alike:
        notes.append(_alike_sentence(alike, next(s for s in scored if s.effect == verdict), floor.effect))
        say(notes[-1])
    scored = _winner_uncertainty(ev, scored, verdict, fits, tau)
    weight = _weight_note(next(s for s in scored if s.effect == verdict), loc, world, odb)
    if weight:
        notes.append(weight)
        say(weight)
    unexplained = _unexplained(next(s for s in scored if s.effect == verdict), loc)
    if unexplained:
        notes.append(unexplained)
        say(unexplained)
    if runner.failures:
        notes.append(f"{len(runner.failures)} simulation(s) failed and scored as far off (first: "
                     f"{runner.failures[0][0]}: {runner.failures[0][1]})")
    return Identification(verdict, tuple(scored), loc, _names(runner, train), _names(runner, held_out), tau,
                          tuple(screened), tuple(notes), runner.simulations - sims0, time.perf_counter() - started,
                          held_loc, stopped, loader, rollouts(), floor.effect if floor.cv is not None else None, frame,
                          work, stability, rod, _against_verdict(support, scored, verdict, focus[0]), alike)


def _fit_effect(runner: Runner, ev: Evaluator, space: ParameterSet, starts: Sequence[np.ndarray], effect: str,
                target: str, held_out: Sequence[int], options: Options, limit: TimeLimit, measured: bool
                ) -> tuple[FitResult, Scored]:
    """An effect fitted fully from the best of `starts`, with its predictions of the held-out recordings."""
    world, odb = runner.prepared[ev.indices[0]].world, runner.odb
    result = fit(ev, space, _best_start(ev, space, starts)[0], max_iterations=options.max_iterations,
                 optimizer=options.optimizer, should_stop=limit.expired)
    return result, _held_out(runner, held_out, [_from_fit(effect, target, result, world, odb, measured)])[0]


def _screening(ev: Evaluator, floor: Model) -> Evaluator:
    """The training recordings a screen replays, with every model `ev` has run known on them: the SCREENED share
    (at least MIN_SCREENED) on which the `floor` model leaves the most chi^2 above the noise. A screen only ranks
    the candidates and gives each full fit its start, and a candidate can gain most where the floor leaves most;
    the full fits, the held-out predictions and the cross-validation replay every recording (and the screens of a
    local effect, `identify`). The screens were about half of a diagnosis' replays."""
    runs = ev.runs(floor)
    k = max(min(MIN_SCREENED, len(runs)), math.ceil(SCREENED * len(runs)))
    if k >= len(runs):
        return ev
    worst = sorted(sorted(range(len(runs)), key=lambda j: -(runs[j].chi2 - len(runs[j].normalised)))[:k])
    sub = Evaluator(ev.runner, [ev.indices[j] for j in worst])
    sub.cache = {m: tuple(r[j] for j in worst) for m, r in ev.cache.items()}
    return sub


def _best_start(ev: Evaluator, space: ParameterSet, starts: Sequence[np.ndarray]) -> tuple[np.ndarray, float]:
    """The start of least chi^2 (the first of equals) and its chi^2; the others' replays cut once they cannot be
    (`Evaluator.runs_below`)."""
    models = [_model(space, x) for x in starts]
    chis = [math.inf if r is None else ev.chi2(m) for m, r in zip(models, ev.runs_below(models))]
    best = int(np.argmin(chis))
    return starts[best], chis[best]


def _chi2_below(ev: Evaluator, model: Model, bound: float) -> float:
    """chi^2 of `model`, or inf once its replays show it above `bound` (a model kept only below it)."""
    runs = ev.runs_below([model], bound)[0]
    return math.inf if runs is None else ev.chi2(model)


def _database_contact(fitted: ParameterSet, friction: Sequence[Parameter]) -> list[Parameter] | None:
    """The ordinary parameters held at the database's contact where `fitted` held another (`Options.contact`),
    else None (no contact among them, or `fitted` already at the database's). Only that way: an effect held at the
    friction model's contact is cross-validated with a contact fitted on the recordings it leaves out, which
    flatters it (the matched proof's small half-plane patch: 28 % better there on the recordings it was not fitted
    on, its one held-out push 27 % worse)."""
    held = {p.name: float(p.value) for p in fitted.entries if p.kind.contact_model and not p.free}
    database = {p.name: float(p.start) for p in friction if p.kind.contact_model}
    if not database or set(held) != set(database) or all(math.isclose(held[k], v) for k, v in database.items()):
        return None
    return _held_contact(friction, database)


def _fit_key(s: Scored) -> tuple[str, str | None]:
    return ("friction", None) if s.effect == "friction" else (s.effect, s.target)


def _with_uncertainty(s: Scored, result: FitResult, tau: float) -> Scored:
    """`s` with the uncertainty of `result`'s Jacobian (differenced at the optimum for every cross-validated
    model; the secant estimate a fit leaves there otherwise), inflated by the residual's correlation time: tau
    correlated samples carry one sample's information (as in `bic`)."""
    std = result.std(inflate=tau)
    return replace(s, std={k: std.get(k, v) for k, v in s.std.items()}, model_std={**s.model_std, **std})


def _winner_uncertainty(ev: Evaluator, scored: list[Scored], verdict: str, fits: dict, tau: float
                        ) -> list[Scored]:
    """The winner's uncertainty from a finite-difference Jacobian at its optimum (a cross-validated model has
    it already; otherwise it is differenced now)."""
    winner = next(s for s in scored if s.effect == verdict)
    result = fits.get(_fit_key(winner))
    if verdict == "none" or result is None or result.differenced:
        return scored
    return [_with_uncertainty(s, differenced(ev, result), tau) if s is winner else s for s in scored]


def _friction_parameters(world, odb, target: str, contact: bool = False) -> list[Parameter]:
    """The ordinary parameters of `target`: its sliding pair's coefficient and its robot pairs' factor; its own
    coefficient instead of the factor when the robot's model gives its links none (the sliding pair, realised
    after it, stays what it says), and alone when it rests on no fixture. With `contact`, where it rests on a
    fixture, also its contact's stiffness and damping (`CONTACT`)."""
    if support_of(world, odb, target) is None:
        kinds = ["friction"]
    else:
        kinds = ["sliding_friction", "robot_friction" if link_friction(world, odb) else "friction"]
        # a rigid object (no hydroelastic modulus: point contact) has only its damping
        kinds += [k for k in CONTACT if contact and kind_named(k).null(world, odb, target) is not None]
    return [Parameter.of(kind, target, world, odb, effect="friction") for kind in kinds]


def _read_friction(ev: Evaluator, work: WorkFit | None, friction: Sequence[Parameter], fitted: dict[str, float],
                   world, odb) -> list[tuple[Scored, FitResult]]:
    """The friction model as the recordings read it, before any simulation: the sliding pair's coefficient held at
    what the work the robot did balances (`work`), the rod's pair and the contact held at the database's, and at
    the friction fit's (`fitted`) where those differ; none where the work reads the database's coefficient (within
    `WorkFit.disagrees` or the coefficient's negligible size).

    A quasi-static push's path does not depend on the surface's coefficient, only the force and the slide-on
    after the rod stops do, so where the world also differs from the model elsewhere (its contact, its servo, its
    step) a fitted coefficient is pulled by whatever the paths leave: a mismatched rect1 world on a rougher surface
    (pair 0.344 for the database's 0.25) had its coefficients fitted to 0.366 with the rod's pair x 1.04, which sent
    one push's rod sticking where it slid (3.3 -> 9.7 noise floors), and `friction` predicted the recordings it was
    not fitted on 3 % worse than `none`: the verdict was `none` while the work read 0.335 +- 0.002. The contact
    the friction fit found is kept beside the database's since the world's contact shows in the slide-on too: an
    ellip1 world on a smoother surface (pair 0.200, read 0.2035) replayed at the reading with the database's contact
    went 16 -> 26 noise floors on one push, with the fitted contact 16 -> 6.3. Held at the reading, a model is
    measured (`Scored.measured`): it is the floor where it predicts better than the fitted coefficients
    (`_cross_validate`), and accepted over `none` where it does not predict worse."""
    sliding = next((p for p in friction if p.kind.name == "sliding_friction"), None)
    if work is None or sliding is None or sliding.target != work.object:
        return []
    lo, hi = sliding.bounds
    value = float(np.clip(work.coefficient, lo, hi))
    size = sliding.kind.negligible(world, odb, sliding.target)
    if not work.disagrees(sliding.start) or (size is not None and abs(value - sliding.start) < size):
        return []
    others = [{p.name: p.start for p in friction}]
    if any(not math.isclose(fitted[p.name], p.start) for p in friction if p is not sliding):
        others.append(fitted)
    out = []
    for held in others:
        space = ParameterSet(tuple(replace(p, value=value, std=work.coefficient_sd) if p is sliding
                                   else replace(p, value=held[p.name], std=None) for p in friction),
                             "the friction the work reads")
        result = fit(ev, space, np.zeros(0))
        out.append((_from_fit("friction", sliding.target, result, world, odb, measured=True), result))
    return out


def _held_contact(friction: Sequence[Parameter], fitted: dict[str, float]) -> list[Parameter]:
    """The ordinary parameters every effect is screened and fitted with: the friction pairs free, the contact's
    stiffness and damping (`Options.contact`) held where the friction model put them. Left free beside an effect
    they take part of it into the contact: in the matched proof's half-plane patch the damping ran to 3 s/m (the
    world's 1) and the patch ended short of where the real one goes on (its held-out push 10 % worse than
    `none`); held, the patch predicts it 39 % better. Given the database's values instead, it holds them there:
    each effect is screened at whichever of the two fits its best screened point better (step 3), since the
    friction model's contact takes up part of an effect where it can (the matched block on a small disc: the
    friction model softened the contact to 0.28 times the database's, and the footprint held there lost to
    `com_offset`)."""
    return [replace(p, value=fitted[p.name]) if p.kind.contact_model else p for p in friction]


def _force_readings(runner: Runner, train: Sequence[int], model: Model, obj: str
                    ) -> tuple[RodReading | None, SupportReading | None]:
    """What the force reads against replays of the training recordings by the friction model with the database's
    rod pair (the simulated rod and force: one replay each, which the rollout cache does not keep): the rod's
    friction while it slid (`cone`), against the fitted rod factor, and the footprint scale the object's torsion
    asks for (`pressure`), replayed once more at that scale where the pushes agree on one that is not uniform (the
    secant calibrates it). Not at the fitted pair: a fit that roughened the rod makes it stick in the replays where
    the real one slid (real ellip3: 1.45 x, no replay slid). Evidence, never a fit: what they read in a simulator
    whose contacts creep (MuJoCo's ellipses: a third of the rod's coefficient, median) is that simulator's, not
    Coulomb's."""
    trials = [runner.prepared[i].trial for i in train]
    fitted = next((s.value for s in model if s.kind == "robot_friction" and s.target == obj), None)
    read_rod = fitted is not None and contact_friction(trials, runner.odb, obj) is not None
    if not read_rod and len(recorded_torsions(trials, runner.odb, obj)) < 2:
        return None, None
    at_one = tuple(replace(s, value=1.0) if s.kind == "robot_friction" and s.target == obj else s for s in model)

    def replays(m: Model) -> list:
        jobs = [runner.job(m, i) for i in train]
        jobs = [replace(j, options=replace(j.options, robot_force=True, joint_track=True)) for j in jobs]
        runner.simulations += len(jobs)
        return [None if o.failed else o.result for o in runner.executor.run(jobs)]

    results = replays(at_one)
    rod = rod_reading(trials, results, runner.odb, obj, 1.0, fitted) if read_rod else None
    bounds = Parameter.of("support_scale", obj, trials[0].world, runner.odb).bounds
    support = calibrated_reading(trials, results, lambda s: replays(at_one + (Setting("support_scale", obj, s),)),
                                 runner.odb, obj, bounds)
    return rod, support


def _against_verdict(support: SupportReading | None, scored: Sequence[Scored], verdict: str, obj: str
                     ) -> SupportReading | None:
    """The reading against the verdict's footprint scale (None: the database's uniform footprint); not judged where
    the verdict's model has what the reading neglects (`SupportReading.outside`: a surface_tilt world read 1.76,
    a grain 1.65-1.74, where their models are uniform footprints)."""
    if support is None:
        return None
    model = next(s.model for s in scored if s.effect == verdict)
    fitted = next((s.value for s in model if s.kind == "support_scale" and s.target == obj), None)
    outside = any(s.kind.startswith(NEGLECTED) and float(s.value) != 0.0 for s in model)
    return replace(support, fitted=None if fitted is None else float(fitted), outside=outside)


def _work_friction(work: WorkFit | None, friction: Sequence[Parameter], fitted: dict[str, float]
                   ) -> dict[str, float] | None:
    """The fitted coefficients with the sliding one the work the robot did measures, where the two disagree
    (`WorkFit.disagrees`): a start for the screens of effects the work seeds (`_friction_starts`). The friction
    fit bends to what the model lacks (independent MuJoCo hex tilted 1 deg: it fitted 0.09 where the force says
    0.34, and from there the true tilt screened worse than level; from the force's coefficient and the work's slope
    it beats the friction fit by 12 %)."""
    sliding = next((p for p in friction if p.kind.name == "sliding_friction"), None)
    if work is None or sliding is None or sliding.target != work.object or not work.disagrees(fitted[sliding.name]):
        return None
    lo, hi = sliding.bounds
    return {**fitted, sliding.name: float(np.clip(work.coefficient, lo, hi))}


def _friction_starts(effect: Effect, frictions: list, measured: dict[str, float] | None) -> list:
    """The friction coefficients an effect's seeds start from, with their coordinates where they have them: the
    fitted and the nominal ones (the friction fit may have taken up what the effect explains, e.g. a heavier
    object's larger push force) and, for an effect whose seeds the work balance reads (`Effect.reads_work`), the
    sliding coefficient it reads them with, where the fit contradicts it (`_work_friction`). The slope and the
    coefficient are one solution of one balance; paired with other effects' seeds the coefficient turned real ellip3
    from anisotropic_friction to a com_offset its held-out pushes reject."""
    return list(frictions) + ([(measured, None)] if measured is not None and effect.reads_work else [])


def _with_friction(x: np.ndarray, friction_x: np.ndarray | None) -> np.ndarray:
    """x with the fitted friction coefficients' own coordinates (they lead every candidate's space), not their
    values converted back and forth: the same point, so the same model as the friction fit's."""
    if friction_x is None:
        return x
    x = np.array(x, dtype=float)
    x[:len(friction_x)] = friction_x
    return x


def _space(friction: Sequence[Parameter], effect, target: str, world, odb,
           measured: dict[str, tuple[float, float]] | None = None,
           region: dict[str, tuple[float, float]] | None = None) -> ParameterSet:
    """The friction coefficients and an effect's parameters, searched together; an effect parameter that a
    direct measurement gives (`_measured`: name -> (value, 1 sigma)) is held at it, one the `region` names
    (`Effect.fit_region`) kept within its bounds there too."""
    measured, region = measured or {}, region or {}

    def bounded(p: Parameter) -> Parameter:
        if p.name not in region or not p.free:
            return p
        lo, hi = max(p.bounds[0], region[p.name][0]), min(p.bounds[1], region[p.name][1])
        return replace(p, bounds=(lo, hi)) if lo < hi else p
    own = tuple(replace(p, value=measured[p.name][0], std=measured[p.name][1]) if p.name in measured else bounded(p)
                for p in effect.parameters(world, odb, target))
    return ParameterSet(tuple(friction) + own, f"{effect.name} on {target}")


def _measured(loader: LoaderEvidence, world) -> dict[str, tuple[float, float]]:
    """Effect parameters the recordings measure before any simulation, by name: (value, 1 sigma). The rod offset
    the contact gaps make evident (`loader.ContactFit`: where the rod sat on the outline while it pushed, from every
    recording) is such a measurement: a fit through a simulation of a world that differs from the model beneath
    the offset moves it to soak up the difference (independent MuJoCo worlds: (+0.8, -4.0) mm measured and true,
    (+3.8, -8.3) mm fitted; (-3.0, +2.7) measured, (-3.5, +3.1) fitted and refused as 6 sigma off the
    measurement), so `pusher_offset` is the measured offset with the friction coefficients fitted to it. So is the
    latency the gaps of recordings pushed at different speeds make evident (`ContactFit.latency`)."""
    return {pname(s.kind, s.target): (s.value, sd) for s, sd in _measured_settings(loader, world)}


def _held_frame(frame: FrameFit | None) -> dict[str, tuple[float, float]]:
    """The recorded frame the pushing samples make evident (`outline.FrameFit`), by parameter name: (value, 1 sigma,
    floored at FRAME_FLOOR). `object_frame` is held there, the friction coefficients fitted to it, as a measured rod
    offset is: fitted through replays of a world that differs from the model elsewhere, the frame went where the
    world's leftovers pulled it (a mismatched rect1 world: the samples read (+2.9, -9.6) mm, +7.0 deg for a true
    (+3.0, -9.5) mm, +6.9 deg; the fit went to (-2.8, -13.0) mm, +10.7 deg and was refused by `_frame_check`, and a
    rod offset was the verdict). Unlike a rod offset the reading is no evidence by itself: a rod offset moves the
    rod in the object's frame the same way where the object kept one yaw, and latencies and masses in mismatched
    worlds made frames of 2 mm and 2 deg evident. So the model must predict as a fitted effect must (`_verdict`)."""
    if frame is None or not frame.evident:
        return {}
    floors = (FRAME_FLOOR[0], FRAME_FLOOR[0], FRAME_FLOOR[1])
    return {name: (value, max(sd, floor))
            for (name, value), sd, floor in zip(frame.values().items(), frame.std, floors)}


def _measured_settings(loader: LoaderEvidence, world) -> list[tuple[Setting, float]]:
    """`_measured` as settings, each with its 1 sigma."""
    fit = loader.contact_fit()
    if fit is None:
        return []
    out = []
    if fit.offset_evident:
        sd = np.sqrt(np.maximum(np.diag(np.asarray(fit.offset_cov, dtype=float)), 0.0))
        out += [(Setting("joint_offset", j, float(v), "pusher_offset"), float(s))
                for j, v, s in zip(fit.joints, fit.offset, sd)]
    if fit.latency_evident and world.robot is not None:
        out.append((Setting("latency", world.robot.name, float(fit.latency), "latency"), float(fit.latency_sd)))
    return out


def measured_model(runner: Runner, train: Sequence[int], held_out: Sequence[int] = ()) -> Model:
    """The calibration the recordings measure before any simulation (`_measured`: a rod offset, a latency), as a
    model: where the objects and the rod are known to be. The forks are measured there (`forks.measure_forks`)."""
    order = list(train) + list(held_out)
    if not order:
        return ()
    loader = read_adjustments([runner.prepared[i] for i in order], range(len(train), len(order)))
    return tuple(s for s, _ in _measured_settings(loader, runner.prepared[order[0]].world))


def _full_fits(order: list[Candidate], best: int, is_measured: Callable[[Candidate], bool]) -> list[Candidate]:
    """The candidates fitted fully, from the screened ones best first: the `best` first; an effect the recordings
    measure before any simulation (`_measured`), since the measurement, not the screen, is its evidence (in a
    world that differs from the model elsewhere it may screen low); and the signature's favourite (the highest
    prior) where its screen removed anything of its floor's chi^2 (`Candidate.screened_floor`), since a screen is
    one step and a flexible effect screens better than a smooth one that fits better (a matched com_offset world:
    the centre of mass, the favourite and the verdict by a wide margin before, screened seventh behind a turned
    patch)."""
    full = order[:best] + [c for c in order[best:] if is_measured(c)]
    favourite = max(order, key=lambda c: c.prior, default=None)
    if favourite is not None and favourite not in full and favourite.screened_chi2 < favourite.screened_floor:
        full.append(favourite)
    return full


def _nested(c: Candidate, s: Scored, order: Sequence[Candidate], fits: dict, world, odb) -> Candidate | None:
    """The candidate of the effect nested in `c`'s (`Effect.reduces_to`: a centre of mass at the centre is a mass),
    started from `s`, `c`'s fit, where that fit's own parameters are negligible, the nested effect's are not (a mass
    5 % or more off the database's) and it fits better than the nested effect's own fit, if any: what the fit found
    is then the nested effect's, and only a fit of that effect can say so (`_fit_reason` refuses a negligible
    effect whatever it removes). None otherwise. Measured (session 66): a mismatched tabletop box with a slug at
    its centre (twice the database's mass) fitted `com_offset` at 0.5 mm with 1.5 x the mass to 1.4 noise floors
    where friction left 4.1, refused as negligible, while `mass`, screened from the friction fit's first basin (a
    coefficient of 0.61 matching the force, where the paths ask for 0.31), was not fitted at all."""
    outer = get_effect(c.effect)
    name = outer.reduces_to
    if name is None or not outer.negligible(world, odb, c.target, s.params):
        return None
    inner = next((o for o in order if (o.effect, o.target) == (name, c.target)), None)
    done = fits.get((name, c.target))
    if inner is None or (done is not None and done.chi2 <= s.chi2):
        return None
    own = {p.name for p in get_effect(name).parameters(world, odb, c.target)}
    values = {k: v for k, v in s.params.items() if k in own}
    if get_effect(name).negligible(world, odb, c.target, values):
        return None  # the fit found nothing of the nested effect either
    start = {**inner.start, **values, **{st.name: st.value for st in s.model if st.effect == "friction"}}
    return replace(inner, start=start, database_contact=c.database_contact, note=f"from {c.effect}'s fit")


def _all_measured(c: Candidate, world, odb, measured: dict[str, tuple[float, float]]) -> bool:
    """Whether every parameter of candidate `c` is held at a measurement (`_measured`)."""
    own = get_effect(c.effect).parameters(world, odb, c.target)
    return bool(own) and all(p.name in measured for p in own)


def _model(space: ParameterSet, x: np.ndarray) -> Model:
    return space.model(space.from_normal(x))


def _names(runner: Runner, indices: Sequence[int]) -> tuple[str, ...]:
    return tuple(runner.prepared[i].name for i in indices)


def _fmt(values: dict[str, float]) -> str:
    return ", ".join(f"{k} = {v:.4g}" for k, v in values.items())


def _from_fit(effect: str, target: str | None, result: FitResult, world, odb, measured: bool = False) -> Scored:
    """The Scored model of a fit: the effect's own parameters (for friction, every coefficient, the target the
    one that moved most in units of its step). `measured`: its own parameters are all held at what the recordings
    measure (`_measured`); one held at a reading that is no evidence by itself (`_held_frame`) is judged as a fitted
    effect is."""
    free, values, std = result.space.free, result.values(), result.std()
    if effect == "friction" and not free:  # held at a reading (`_read_friction`): the coefficients read
        own = [p for p in result.space.entries if p.std is not None]
        target = own[0].target
    elif effect == "friction":
        own = list(free)
        target = free[max(range(len(free)), key=lambda i: abs(result.x[i]))].target
    else:  # the effect's parameters, fitted or held at a measurement (`_measured`)
        own = [p for p in result.space.entries if p.effect == effect]
    params = {p.name: (values[p.name] if p.free else float(p.value)) for p in own}
    std = {**{p.name: float(p.std) if p.std is not None else math.nan for p in own if not p.free}, **std}
    derived = get_effect(effect).describe(world, odb, target, params)
    return Scored(effect, target, params, {p.name: std[p.name] for p in own}, result.model(),
                  result.space.dim + sum(1 for p in own if not p.free),
                  result.chi2, result.n, error=pose_error_of(result.runs), derived=derived,
                  evaluations=result.evaluations, model_std=std, at_bound=result.at_bound(),
                  measured=measured)


def _score(models: Sequence[Scored], tau: float) -> list[Scored]:
    """BIC on tau-discounted samples; score = log evidence against `none`; best first."""
    from dataclasses import replace

    out = [replace(m, bic=bic(m.chi2, m.n, m.k, tau)) for m in models]
    b_none = next((m.bic for m in out if m.effect == "none"), max(m.bic for m in out))
    out = [replace(m, score=(b_none - m.bic) / 2.0) for m in out]
    return sorted(out, key=lambda m: -m.score)


def _held_out(runner: Runner, held_out: Sequence[int], scored: list[Scored]) -> list[Scored]:
    if not held_out:
        return scored
    from dataclasses import replace

    runs = runner.run_many([s.model for s in scored], list(held_out))
    out = []
    for s, r in zip(scored, runs):
        chi2, n = chi2_of(r)
        out.append(replace(s, held_out_chi2=chi2, held_out_n=n, held_out_error=pose_error_of(r),
                           held_out_runs=tuple(r)))
    return out


def _fit_reason(s: Scored, none: Scored, friction: Scored | None, world, odb) -> str | None:
    """Why `s` is not worth its parameters on the recordings it was fitted on (None: it is), see `_verdict`."""
    if s.contradicted:
        return s.contradicted
    if s.at_bound:
        return (f"{s.effect}'s fit ended on the bound of {_fmt(s.at_bound)} and asks for more: the recordings want "
                "values outside the physical range (for a place: beyond the reach of the evidence that seeded it), so "
                "this model does not describe them (not a finding)")
    if s.effect not in ("none", "friction") and get_effect(s.effect).negligible(world, odb, s.target, s.params):
        return f"{s.effect}'s parameters ({_fmt(s.params)}) are too small to matter physically"
    base = none if s.effect == "friction" or friction is None else friction
    gain = (base.chi2 - s.chi2) / max(base.chi2 - base.n, 1e-12)
    if gain < (0.0 if s.measured else MIN_GAIN if base.rms >= NOISE_RMS else NEAR_NOISE_GAIN):
        return f"{s.effect} removes only {100 * gain:.0f} % of the residual above the noise that {base.effect} leaves"
    return None


def _checked_against(s: Scored, loader: LoaderEvidence, frame: FrameFit | None = None, world=None,
                     odb=None) -> Scored:
    """`s` marked `contradicted` when direct evidence, read before any simulation, rules it out: a fitted rod
    offset that the rod-to-outline gaps while pushing do not show (`ContactFit`: they measure the offset without
    simulating, so a fit that puts the rod elsewhere is soaking up something else), beyond NOISE_SIGMAS of the
    gaps' uncertainty (Mahalanobis), the same rule that makes the gaps' own offset evident; likewise a fitted
    latency (`_latency_check`) or size (`_scale_check`) the gaps do not show and a fitted recorded frame that the
    pushing samples do not show (`outline.FrameFit`, where they pin it: `_frame_check`)."""
    from dataclasses import replace

    if s.effect == "object_frame":
        why = _frame_check(s, frame)
        return replace(s, contradicted=why) if why else s
    fit = loader.contact_fit()
    if s.effect == "latency":
        why = _latency_check(s, fit)
        return replace(s, contradicted=why) if why else s
    if s.effect == "object_scale":
        why = _scale_check(s, fit, None if world is None else outline_radius(world, odb, s.target))
        return replace(s, contradicted=why) if why else s
    if s.effect != "pusher_offset" or fit is None:
        return s
    offsets = {k[len("joint_offset["):-1]: v for k, v in s.params.items() if k.startswith("joint_offset[")}
    fitted = np.array([offsets.get(j, 0.0) for j in fit.joints])  # relative to the raw recording (`raw_relative`)
    gap = fitted - np.array(fit.offset)
    sigmas = float(np.sqrt(max(0.0, gap @ np.linalg.pinv(np.array(fit.offset_cov)) @ gap)))
    if sigmas <= NOISE_SIGMAS:
        return s
    return replace(s, contradicted=(
        f"pusher_offset's fitted rod offset ({1e3 * fitted[0]:+.1f}, {1e3 * fitted[1]:+.1f}) mm is not what the "
        f"rod-to-outline gaps while pushing show ({1e3 * fit.offset[0]:+.1f}, {1e3 * fit.offset[1]:+.1f}) mm, "
        f"{sigmas:.0f} sigma apart: it soaks up something else"))


def _latency_check(s: Scored, gaps: ContactFit | None) -> str | None:
    """Why the contact gaps rule out `s`'s fitted latency (None: they do not, or cannot tell). Recordings pushed at
    different speeds measure the latency directly (`ContactFit.latency`: the recorded rod leads the real one by
    tau x its speed); a fitted latency off that by more than NOISE_SIGMAS of its uncertainty, and by more than
    moves the rod NEGLIGIBLE at the recordings' typical speed, soaks up something else."""
    if gaps is None or gaps.latency is None or gaps.latency_sd is None or not gaps.speed:
        return None
    fitted = next(iter(s.params.values()), 0.0)
    off = abs(fitted - gaps.latency)
    if off <= NOISE_SIGMAS * gaps.latency_sd or off * gaps.speed <= NEGLIGIBLE:
        return None
    return (f"latency's fitted {1e3 * fitted:+.0f} ms is not what the rod-to-outline gaps of recordings pushed at "
            f"different speeds show ({1e3 * gaps.latency:+.0f} +- {1e3 * gaps.latency_sd:.0f} ms): it soaks up "
            "something else")


def _scale_check(s: Scored, gaps: ContactFit | None, radius: float | None) -> str | None:
    """Why the contact gaps rule out `s`'s fitted size (None: they do not, or cannot tell). A size k moves the
    outline where the rod meets it by about (k - 1) r (r: `object_scale.outline_radius`), and the gaps
    measure that move directly (`ContactFit.inflation`, micrometres to tenths of a millimetre). A fitted size
    whose move is off the measured one by more than NOISE_SIGMAS of its uncertainty, a negligible size
    (NEGLIGIBLE) and SIZE_SPREAD of the move (the outline's distances from its centre differ from r by that
    much), whichever is largest, soaks up something else: independent MuJoCo worlds, whose stiff rod does not
    sink into the object as Drake's compliant one does, were fitted 1.75 % larger (+0.9 mm) where the gaps
    measured -0.01 +- 0.03 mm."""
    if gaps is None or radius is None:
        return None
    scale = s.params.get(pname("object_scale", s.target), 1.0)
    moved = (scale - 1.0) * radius
    tolerance = max(NOISE_SIGMAS * gaps.inflation_sd, NEGLIGIBLE, SIZE_SPREAD * abs(moved))
    if abs(moved - gaps.inflation) <= tolerance:
        return None
    return (f"object_scale's fitted size ({100 * (scale - 1.0):+.1f} %, the outline {1e3 * moved:+.2f} mm where the "
            f"rod meets it) is not what the rod-to-outline gaps while pushing show ({1e3 * gaps.inflation:+.2f} +- "
            f"{1e3 * gaps.inflation_sd:.2f} mm): it soaks up something else")


def _frame_check(s: Scored, frame: FrameFit | None) -> str | None:
    """Why the pushing samples rule out `s`'s fitted frame (None: they do not, or cannot tell). Two tests, both on
    what the samples measure directly, before any simulation:
    - the gaps: with the fitted frame the rod sits further off the outline while it pushed than with the model's
      own frame, by more than a negligible gap (loader.NEGLIGIBLE, 0.5 mm, added in quadrature to the gap's RMS).
      A frame that is really there brings the rod onto the
      outline; one a fit moved to soak up a mismatched world's leftovers takes it off (independent MuJoCo worlds:
      RMS 0.34 -> 2.71 mm, 0.54 -> 0.81 mm, 0.34 -> 1.15 mm, all three chosen under the second test alone). Along
      directions the samples do not pin (one face pushed) the gaps do not change, and nothing is contradicted;
    - where the samples pin the frame (the fit stopped by no bound), a component off the samples' own frame by
      more than NOISE_SIGMAS of its uncertainty, floored at FRAME_FLOOR: a fit that overshoots the samples' frame
      in their own direction (real ellip3: -9 deg where they say -5) lowers the gaps and still soaks up a turn."""
    if frame is None:
        return None
    fitted = [s.params.get(f"frame_{k}[{s.target}]", 0.0) for k in ("x", "y", "yaw")]
    described = (f"object_frame's fitted frame ({1e3 * fitted[0]:+.1f}, {1e3 * fitted[1]:+.1f}) mm, "
                 f"{math.degrees(fitted[2]):+.1f} deg")
    modelled, moved = frame.rms_at(0.0, 0.0, 0.0), frame.rms_at(*fitted)
    if moved ** 2 > modelled ** 2 + NEGLIGIBLE ** 2:
        return (f"{described} puts the rod {1e3 * moved:.2f} mm (RMS) off the outline while it pushed, where the "
                f"model's own frame leaves {1e3 * modelled:.2f} mm: it soaks up something else")
    if frame.at_bound:
        return None
    seen = (frame.x, frame.y, frame.yaw)
    floors = (FRAME_FLOOR[0], FRAME_FLOOR[0], FRAME_FLOOR[1])
    off = [abs(f - v) / max(sd, fl) for f, v, sd, fl in zip(fitted, seen, frame.std, floors)]
    if max(off) <= NOISE_SIGMAS:
        return None
    return (f"{described} is not where the rod touched the outline while it pushed "
            f"({1e3 * seen[0]:+.1f}, {1e3 * seen[1]:+.1f}) mm, {math.degrees(seen[2]):+.1f} deg, {max(off):.0f} "
            f"sigma apart: it soaks up something else")


def _cv_reason(s: Scored, floor: Scored) -> str | None:
    """Why `s` does not predict unseen recordings better than `floor` (None: it does), see `_verdict`."""
    if floor.cv is None:
        return None  # nothing to cross-validate on (one recording): the fit's criteria alone decide
    if s.cv is None:
        return f"{s.effect} was not cross-validated (its fit is not worth its parameters against {floor.effect})"
    if floor.cv.excess() <= 0.0:
        return f"{floor.effect} already predicts every recording it was not fitted on to the noise floor"
    share, needed = s.cv.compare(floor.cv), (0.0 if s.measured else CV_GAIN)
    head = (f"{s.effect} removes {100 * share:.0f} % of what {floor.effect} leaves on recordings neither was fitted "
            f"on ({_better_in(s, floor)}")
    if share < needed:
        return head + ("; cross-validated, the geometric mean over the recordings; "
                       + (f"at least {100 * needed:.0f} % needed)" if needed else
                          "a measured effect must not predict worse)"))
    weakest = s.cv.weakest(floor.cv) if needed else None  # a measured effect is evidenced by its measurement
    if weakest is not None and weakest[1] < needed:
        name, least = weakest
        return head + (f"), but {100 * least:.0f} % without {name}: one recording carries the gain (at least "
                       f"{100 * needed:.0f} % needed with any one left out)")
    return None


def _better_in(s: Scored, floor: Scored) -> str:
    """In how many recordings `s` predicts better than the floor: the folds' spread behind the mean gain."""
    better, compared = s.cv.better_in(floor.cv)
    return f"better on {better} of {compared} recordings"


def _acceptable(s: Scored, none: Scored, friction: Scored | None, world, odb) -> str | None:
    """Why `s` is not accepted over the ordinary model (None when it is), see `_verdict`."""
    why = _fit_reason(s, none, friction, world, odb)
    if why is not None:
        return why
    floor = none if s.effect == "friction" or friction is None else friction
    return _cv_reason(s, floor)


def _verdict(scored: list[Scored], world, odb) -> tuple[str, str | None, Scored]:
    """The model that predicts the recordings it was not fitted on best, among those worth their parameters.

    The floor is the ordinary model: `friction` (the friction coefficients fitted) when it is accepted over
    `none`, else `none`. An effect (its parameters fitted together with the friction coefficients) is accepted
    when
    - no parameter of its fit was stopped by a bound (`FitResult.at_bound`: the data ask for a value outside the
      physical range, so the model family is wrong and the value on the bound is no finding);
    - its own parameters are not all negligible (`Effect.negligible`: e.g. a centre of mass moved by less than
      a millimetre only soaks up the error of the start poses);
    - on the recordings it was fitted on, its extra parameters remove at least MIN_GAIN of the ordinary model's
      chi^2 above the noise floor (NEAR_NOISE_GAIN when that model is already within NOISE_RMS of the floor);
    - cross-validated (`crossval`: every recording predicted by the model fitted without it), it removes at
      least CV_GAIN of the chi^2 above the noise that the floor leaves on those predictions (`compare`: the
      geometric mean of the per-recording ratios, so every recording weighs alike), and still does with any one
      recording left out (`Prediction.weakest`): a model fitted without a recording predicts it only from what
      the others show, so a gain that one recording carries is no prediction;
    - an effect whose parameters the recordings measure before any simulation (`Scored.measured`: a rod offset,
      a latency from the contact gaps, `_measured`) is evidenced by that measurement; of the simulation it needs
      only not to predict worse (both gains above zero instead of MIN_GAIN and CV_GAIN): where the world differs
      from the model in ways no effect names, that difference may dwarf what the effect changes (a 60 ms
      latency in a MuJoCo world: 12 sigma in the gaps, 8.5 -> 8.1 noise floors in the replays).
    The verdict is the accepted effect that removes the most, else the floor. `friction` is
    accepted over `none` by the same rules, and it is the verdict only where its coefficients moved beyond their
    negligible size (`NEGLIGIBLE_FRICTION` of the database's): near the noise floor a few per cent of coefficient
    buy a large share of what `none` leaves (the matched tabletop's clean world: 2 %, cross-validated 25 %), and
    with the contact fitted (`Options.contact`) its stiffness and damping, which are no finding, can carry the
    whole gain. The floor stays the `friction` model then: what the effects were judged against.
    """
    floor, accepted, reasons = _selection(scored, world, odb)
    if accepted:
        best = max(accepted, key=lambda m: _gain(m, floor))
        why = (f"{best.effect} removes {100 * best.cv.compare(floor.cv):.0f} % of what {floor.effect} leaves on "
               f"recordings neither was fitted on ({_better_in(best, floor)})"
               if best.cv is not None and floor.cv is not None
               else f"{best.effect} is worth its parameters against {floor.effect}")
        return best.effect, ("; ".join(reasons) + f"; {why}: the verdict") if reasons else None, floor
    if floor.effect == "friction" and _coefficients_negligible(floor, world, odb):
        moved = _fmt({st.name: st.value for st in _coefficients(floor)})
        reasons.append(f"friction's coefficients ({moved}) are within {100 * NEGLIGIBLE_FRICTION:.0f} % of the "
                       "object database's: too small to matter physically (what the model gains beside them is its "
                       "contact's, a solver's step or a servo as readily as a material, no finding), so it stays the "
                       "floor the effects were judged against, not the verdict")
        return "none", "; ".join(reasons) + "; no effect of the catalog is confirmed", floor
    tail = "no effect of the catalog is confirmed" + ("" if floor.effect == "none" else
                                                      ", the friction the work reads is the model" if floor.measured
                                                      else ", the fitted friction is the model")
    return floor.effect, ("; ".join(reasons) + f"; {tail}") if reasons else None, floor


def _selection(scored: list[Scored], world, odb) -> tuple[Scored, list[Scored], list[str]]:
    """(the floor, the effects accepted over it, why each refused model was refused), see `_verdict`."""
    by = {s.effect: s for s in scored if s.effect in ("none", "friction")}
    none, friction = by["none"], by.get("friction")
    reasons = []
    floor = none
    if friction is not None:
        why = _acceptable(friction, none, None, world, odb)
        if why is None:
            floor = friction
        else:
            reasons.append(why)
    accepted = []
    for s in scored:
        if s.effect in ("none", "friction"):
            continue
        why = _acceptable(s, none, friction if floor is friction else None, world, odb)
        if why is None:
            accepted.append(s)
        else:
            reasons.append(why)
    return floor, accepted, reasons


def _gain(s: Scored, floor: Scored) -> float:
    """What the selection ranks accepted effects by: the share of the floor's cross-validated excess `s` removes
    (its score where nothing was cross-validated)."""
    return s.cv.compare(floor.cv) if s.cv is not None and floor.cv is not None else s.score


@dataclass(frozen=True)
class Alike:
    """An accepted effect whose predictions the verdict's do not beat on the recordings (`Prediction.separated`):
    the recordings support both, and the verdict leads it by chance as readily as by physics."""

    effect: str
    share: float  # of the floor's cross-validated excess it removes (the verdict's: `Scored.cv_share`)
    p: float  # one-sided p that the verdict predicts better
    better: int  # recordings the verdict predicts better
    compared: int

    def to_json(self) -> dict[str, Any]:
        return {"effect": self.effect, "share": round(self.share, 3), "p": round(self.p, 4),
                "verdict_better_in": self.better, "compared": self.compared}


def _alike(scored: list[Scored], verdict: str, world, odb) -> tuple[Alike, ...]:
    """The accepted effects that predict the recordings neither was fitted on as well as the verdict does: none
    told apart from it at ALIKE_P, best first. Empty when the verdict is the floor (no effect accepted) or
    nothing was cross-validated."""
    floor, accepted, _ = _selection(scored, world, odb)
    winner = next(s for s in scored if s.effect == verdict)
    if winner.cv is None or floor.cv is None:
        return ()
    alike = []
    for s in accepted:
        if s.effect == verdict or s.cv is None:
            continue
        p = winner.cv.separated(s.cv)
        if p >= ALIKE_P:
            better, compared = winner.cv.better_in(s.cv)
            alike.append(Alike(s.effect, s.cv.compare(floor.cv), p, better, compared))
    return tuple(sorted(alike, key=lambda a: -a.share))


def _alike_sentence(alike: Sequence[Alike], winner: Scored, floor: str) -> str:
    """What the report says of the effects the recordings do not tell apart from the verdict."""
    names = ", ".join(a.effect for a in alike)
    each = "; ".join(f"{a.effect} {100 * a.share:.0f} %, {winner.effect} better on {a.better} of {a.compared} "
                     f"recordings, p {a.p:.2f}" for a in alike)
    return (f"{names} also predict{'s' if len(alike) == 1 else ''} the recordings neither was fitted on, as well as "
            f"{winner.effect} does ({winner.effect} removes {100 * (winner.cv_share or 0.0):.0f} % of what {floor} "
            f"leaves; {each}; one-sided Wilcoxon signed-rank over the recordings, p < {ALIKE_P} to tell them apart): "
            f"the recordings support each of them, and {winner.effect} leads by no more than chance; a push where "
            f"their predictions part would decide")


def _coefficients(s: Scored) -> list[Setting]:
    """The friction coefficients (the pairs, or an object's own) of the `friction` model, not its contact's."""
    return [st for st in s.model if st.effect == "friction" and not kind_named(st.kind).contact_model]


def _coefficients_negligible(s: Scored, world, odb) -> bool:
    """Every friction coefficient of the `friction` model `s` within its negligible size of the database's."""
    sized = [(st, kind_named(st.kind)) for st in _coefficients(s)]
    sized = [(st, k, k.negligible(world, odb, st.target)) for st, k in sized]
    return bool(sized) and all(size is not None and abs(st.value - k.null(world, odb, st.target)) < size
                               for st, k, size in sized)


def _stability(scored: list[Scored], verdict: str, world, odb) -> Stability | None:
    """`_verdict` repeated on the cross-validated predictions without each recording in turn (`Stability`): the
    fits stay as they are, only the recordings the selection weighs change. None without cross-validation on at
    least MIN_FOLDS recordings (leaving one of two out leaves one recording to decide)."""
    from dataclasses import replace

    none = next(s for s in scored if s.effect == "none")
    if none.cv is None or len(none.cv.each) < MIN_FOLDS:
        return None
    without = {name: _verdict([replace(s, cv=s.cv.without(name)) if s.cv is not None else s for s in scored],
                              world, odb)[0] for name in none.cv.each}
    return Stability(verdict, without)


def _weight_note(winner: Scored, loc: Localisation, world, odb) -> str | None:
    """What the report says when the verdict moved an object's weight or its sliding coefficient: a quasi-static
    push measures only their product (the force it takes is mu m g, and the path does not depend on it), so a
    heavier object on the database's surface and a rougher surface under the database's object push alike; only
    the slide-on after the rod stops, (v^2 / 2 mu g), depends on mu alone (a millimetre or less at the MIT
    data's speeds). Said when the product moved by a tenth or more."""
    if winner.effect not in ("friction", "mass"):
        return None
    from ..sim.friction import combined_friction
    from ..sim.shapes import mass_properties
    from .effects.base import model_friction, movable_observed

    for obj in movable_observed(world, odb, [o.object for o in loc.objects]):
        surface = support_of(world, odb, obj)
        if surface is None:
            continue
        def pair(model: Model) -> float:
            return combined_friction(model_friction(model, world, odb, obj), model_friction(model, world, odb, surface))
        m0 = mass_properties(odb, world.objects[obj].type).mass
        m = float(winner.params.get(pname("mass", obj), m0))
        mu0, mu = pair(()), pair(winner.model)
        if mu0 <= 0 or abs(math.log(mu * m / (mu0 * m0))) < 0.1:
            continue
        return (f"{obj} on {surface}: the fitted model pushes with weight x sliding coefficient = {m:.3g} kg x "
                f"{mu:.3g} = {mu * m:.3g} kg (the database: {m0:.3g} kg x {mu0:.3g}); quasi-static pushes measure only "
                f"that product: a {mu * m / mu0:.3g} kg {obj} on the database's surface (`mass`) and a coefficient "
                f"of {mu * m / m0:.3g} under the database's {m0:.3g} kg (`friction`) push alike; only the slide-on "
                f"after the rod stops, which the coefficient alone sets, tells them apart")
    return None


def _unexplained(winner: Scored, loc: Localisation) -> str | None:
    """What the report says when the chosen model still predicts recordings it was not fitted on far above the
    noise (UNEXPLAINED noise floors): the world differs from every model tried, and the verdict is the effect
    that predicts best, not a complete explanation. When the nominal residual starts at the first contact in most
    recordings, the object model (its outline, size, the frame the recording tracks) is named first: physics left
    out acts once the object moves (a patch, a post, a tilt), an object model error from the moment the rod meets
    the outline."""
    if winner.cv is None or not winner.cv.n:
        return None
    rms = math.sqrt(winner.cv.chi2 / winner.cv.n)
    if rms <= UNEXPLAINED:
        return None
    text = (f"the chosen model ({winner.effect}) still predicts the recordings it was not fitted on at {rms:.1f} "
            f"noise floors: the world also differs from the model in ways no effect of the catalog names (contact, "
            f"the robot's servo, the object model); the verdict is the effect that predicts best, not a complete "
            f"explanation")
    onsets = [o.features.get("onset_rel") for o in loc.objects if o.significant]
    early = sum(1 for v in onsets if v is not None and v <= FIRST_CONTACT)
    if onsets and early > len(onsets) / 2:
        text += (f"; in {early} of {len(onsets)} recordings the residual starts at the first contact, where the "
                 f"rod meets the outline: the object model (its outline, size, the frame the recording tracks) is "
                 f"the first suspect")
    return text


def _rank(scored: list[Scored], verdict: str, floor: Scored) -> list[Scored]:
    """The verdict first, then the others by the share of the floor's cross-validated excess they remove (their
    score without one), each with that share."""
    from dataclasses import replace

    def key(s: Scored) -> tuple:
        return (s.effect != verdict, s.cv_share is None, -(s.cv_share if s.cv_share is not None else s.score))
    shared = [replace(s, cv_share=s.cv.compare(floor.cv)) if s.cv is not None and floor.cv is not None else s
              for s in scored]
    return sorted(shared, key=key)


def _cross_validate(runner: Runner, ev: Evaluator, scored: list[Scored], fits: dict, loc: Localisation,
                    held_names: Sequence[str], world, odb, variants: Sequence[tuple[Scored, FitResult]] = ()
                    ) -> tuple[list[Scored], dict]:
    """`none`, `friction` and every effect worth its parameters against the floor (`_fit_reason`) predict each
    recording they were not fitted on (`crossval`): the held-out ones from their fit, each fitted one from the fit
    without it. The floor is known once `friction` is: it is `friction` if that is accepted over `none`.
    `variants`: other forms of the friction model with their fits (its contact held at the database's, its
    coefficient held at the work's reading: `_read_friction`); of those worth their parameters, the one that
    predicts best (`_better_floor`, in turn) is `friction` from then on. Nothing is cross-validated with a single
    recording. Returns the models with `cv` and the fits (those cross-validated with their Jacobian differenced at
    the optimum, reused for the uncertainty)."""
    if len(ev.indices) + len(held_names) < 2:
        return scored, fits

    def validated(s: Scored) -> Scored:
        nonlocal fits
        s, fits = _validated(runner, ev, s, fits, loc)
        return s

    by = {s.effect: s for s in scored if s.effect in ("none", "friction")}
    none = validated(by["none"])
    friction = by.get("friction")
    if friction is not None and _fit_reason(friction, none, None, world, odb) is None:
        friction = validated(friction)
    key = ("friction", None)
    for variant, result in variants:
        if friction is None or _fit_reason(variant, none, None, world, odb) is not None:
            continue
        if friction.cv is None and not variant.measured:  # a form of a fit not worth its parameters
            continue
        kept = fits[key]
        fits = {**fits, key: result}
        alternative = validated(variant)
        if friction.cv is None or _better_floor(friction, alternative) is alternative:
            friction = alternative
        else:
            fits = {**fits, key: kept}
    floor_friction = friction if friction is not None and _acceptable(friction, none, None, world, odb) is None \
        else None
    out = []
    for s in scored:
        if s.effect == "none":
            out.append(none)
        elif s.effect == "friction":
            out.append(friction)
        elif (s.effect, s.target) in fits and _fit_reason(s, none, floor_friction, world, odb) is None:
            out.append(validated(s))
        else:
            out.append(s)
    return out, fits


def _better_floor(a: Scored, b: Scored) -> Scored:
    """Of two forms of the ordinary model (the friction coefficients with the contact fitted, held at the
    database's, or the sliding one held at the work's reading), the one that predicts the recordings it was not
    fitted on better (`Prediction.compare`, each recording alike); `a` on a tie. An effect screened at the
    database's contact is judged against the floor that has it too, else it is credited with the contact: a
    mismatched tri1 world's friction model with its contact fitted predicted 6 of 8 recordings 1.2-4.5 times
    worse than at the database's, and a post that touched two of them took the verdict at the database's contact
    (its held-out pushes 49 % better, 193 mm from the real box)."""
    if a.cv is None or b.cv is None:
        return a
    return b if b.cv.compare(a.cv) > 0.0 else a


def _validated(runner: Runner, ev: Evaluator, s: Scored, fits: dict, loc: Localisation) -> tuple[Scored, dict]:
    """`s` with `cv`: each fitted recording predicted by the fit without it, each held-out one by the fit; and the
    fits with `s`'s Jacobian differenced at its optimum."""
    loo = len(ev.indices) > 1
    if s.effect == "none":
        runs = list(loc.runs) if loo else []
        params, fitted = [{}] * len(runs), {}
    else:
        key = _fit_key(s)
        fit_result, runs, params = predict_left_out(runner, ev, fits[key]) if loo else (fits[key], [], [])
        fits, fitted = {**fits, key: fit_result}, fit_result.values()

    def own(values: dict[str, float]) -> dict[str, float]:
        return {k: v for k, v in values.items() if k in s.params}
    held = list(s.held_out_runs)  # predicted by the fit on every fitted recording
    return replace(s, cv=prediction(list(runs) + held, [own(p) for p in params] + [own(fitted)] * len(held))), fits
