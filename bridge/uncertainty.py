"""How sure is the state after a session? Fact probabilities from the uncertainty of the physics.

A box pushed near its tipping point may or may not have fallen in the real world, whatever the nominal
simulation says. `sample_session` replays a recording N times with parameters drawn from what is known about
them, infers the facts of each replay, and gives each fact the share of samples in which it holds
(`bridge.probability.wilson_interval` gives its 95 % interval).

What is drawn:
- from a fitted parameter file or a diagnosed scene file (`--params` / `--scene`): every entry that carries a
  `std` (1 sigma: a fit's spread or curvature, the diagnosis' curvature), around its value;
- without one (or when no entry carries a `std`): the object database's documented ranges (`physics.friction_sd`,
  `mass_sd` relative, `com_sd` in metres; odb/types/base.yaml) for the friction of every object the nominal
  replay re-evaluates (those that moved and what touched them: the table under a pushed box too) and the mass
  and centre of mass of the free ones. Objects nothing happened to are left alone: their facts cannot change.

How: a Latin hypercube (scipy.stats.qmc), mapped through each parameter's normal quantiles and kept within the
kind's physical bounds. Whether a box tips is a threshold in a few parameters (mostly the frictions); a Latin
hypercube stratifies every parameter's marginal into N equally likely slices, so such a share is estimated with
less variance than by independent draws at the same N. Sigma points (an unscented transform) were not used:
they estimate means and covariances of smooth outputs and say nothing reliable about the probability of a
discontinuous event like tipping.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np
from scipy.stats import norm, qmc

from .errors import BridgeError
from .inference import infer_state
from .odb import ObjectDatabase
from .params import ParameterSet, Setting, apply_model, kind_named
from .probability import wilson_interval
from .rollout.executors import Executor
from .rollout.rollout import Job, Rollout
from .sim.shapes import mass_properties
from .sim.simulate import SimOptions
from .teleop import SessionResult, run_session
from .timelimit import STOPPED, TimeLimit
from .values import Fact, Pose
from .world import WorldState

METHOD = "latin hypercube, normal marginals clipped to the kinds' bounds"


@dataclass(frozen=True)
class Uncertain:
    """One drawn parameter: a kind on a target, its mean and 1 sigma, where that comes from."""

    kind: str
    target: str
    mean: float
    sd: float
    source: str  # "params.yaml", "object database", ...

    @property
    def name(self) -> str:
        return f"{self.kind}[{self.target}]"


@dataclass(frozen=True, eq=False)
class SampledSession:
    """The nominal session and N replays with drawn parameters, their facts and what the facts' shares are."""

    nominal: SessionResult
    parameters: tuple[Uncertain, ...]
    draws: np.ndarray  # (N, len(parameters)) values
    finals: tuple[dict[str, Pose] | None, ...]  # each sample's final poses (None: the replay failed)
    facts: tuple[frozenset[Fact] | None, ...]  # each sample's inferred facts
    failures: tuple[str, ...]
    probabilities: dict[Fact, float]  # every fact that held in any successful sample, or in the nominal state
    world: WorldState  # the nominal state, with the probabilities of the facts the samples disagree on
    requested: int | None = None  # samples asked for (None: as many as were replayed)
    stopped: str | None = None  # "time limit": fewer samples than requested were replayed
    time_limit: float | None = None  # s, when one was set

    @property
    def samples(self) -> int:
        """Successful samples (what the probabilities count)."""
        return sum(f is not None for f in self.facts)


def parameters_from_file(parameters: ParameterSet, world: WorldState, odb: ObjectDatabase) -> list[Uncertain]:
    """The entries of a fitted or diagnosed file that carry an uncertainty and name something in `world`."""
    return [Uncertain(p.kind.name, p.target, float(p.value), float(p.std), parameters.source)
            for p in parameters.fixed if p.std and p.kind.select(p.target, world, odb)]


def default_parameters(rollout: Rollout, odb: ObjectDatabase, objects: Sequence[str]) -> list[Uncertain]:
    """The object database's ranges for the friction of `objects` and the mass and centre of mass of the free
    ones, around the rollout's values (a scene file's, else the database's)."""
    world, values = rollout.world, rollout.values
    out = []
    for name in objects:
        obj_type = odb.get(world.objects[name].type)
        phys, current = obj_type.physics, values.objects.get(name)
        mu = current.friction if current is not None and current.friction is not None else phys.friction
        out.append(Uncertain("friction", name, mu, phys.friction_sd * mu, "object database"))
        if obj_type.fixed:
            continue
        props = mass_properties(odb, obj_type.name)
        mass = current.mass if current is not None and current.mass is not None else props.mass
        com = current.com if current is not None and current.com is not None else props.com
        out.append(Uncertain("mass", name, float(mass), phys.mass_sd * float(mass), "object database"))
        out += [Uncertain(kind, name, float(com[axis]), phys.com_sd, "object database")
                for axis, kind in enumerate(("com_x", "com_y"))]
    return [u for u in out if u.sd > 0]


def draw(parameters: Sequence[Uncertain], n: int, world: WorldState, odb: ObjectDatabase, seed: int = 0,
         method: str = "lhs") -> np.ndarray:
    """(n, d) values: a Latin hypercube (`method` "lhs"; "mc": independent draws, to compare) through normal
    quantiles, kept inside each kind's bounds."""
    if method not in ("lhs", "mc"):
        raise BridgeError(f"unknown sampling method {method!r}; methods: lhs, mc")
    if not parameters:
        return np.zeros((n, 0))
    rng = np.random.default_rng(seed)
    u = qmc.LatinHypercube(d=len(parameters), seed=rng).random(n) if method == "lhs" else rng.random((n, len(parameters)))
    z = norm.ppf(np.clip(u, 1e-6, 1 - 1e-6))
    values = np.array([p.mean for p in parameters]) + z * np.array([p.sd for p in parameters])
    for j, p in enumerate(parameters):
        lo, hi = kind_named(p.kind).bounds(world, odb, p.target)
        values[:, j] = np.clip(values[:, j], lo, hi)
    return values


def sample_session(rollout: Rollout, odb: ObjectDatabase, samples: int, *, executor: Executor,
                   parameters: Sequence[Uncertain] | None = None, seed: int = 0, method: str = "lhs",
                   options: SimOptions = SimOptions(),
                   event_period: float | None = None, on_event: Callable[[dict], None] | None = None,
                   progress: Callable[[float, float], None] | None = None,
                   sample_progress: Callable[[int, int], None] | None = None,
                   time_limit: float | None = None) -> SampledSession:
    """Replay `rollout` once as it is (in this process: on-line events, `progress` in simulated seconds), then
    `samples` times with drawn parameters on `executor` (`sample_progress(done, samples)` after each);
    `parameters` None: the object database's ranges for what the nominal replay re-evaluated. A replay that
    fails is counted, not counted in the probabilities. `time_limit` (s, from the call): once it has passed no
    further sample is waited for (at least one is); the shares are over the samples replayed (`stopped`, and
    their intervals widen accordingly)."""
    if not isinstance(samples, int) or isinstance(samples, bool) or samples < 1:
        raise BridgeError(f"samples must be a whole number >= 1, got {samples!r}")
    limit = TimeLimit(time_limit)
    nominal = run_session(rollout, odb, options=options, event_period=event_period, on_event=on_event,
                          progress=progress)
    world = rollout.world
    if parameters is None:
        touched = [n for n in nominal.inference.evaluated if n in world.objects]
        parameters = default_parameters(rollout, odb, touched)
    parameters = tuple(parameters)
    draws = draw(parameters, samples, world, odb, seed, method)
    replay = replace(options, contacts=True, final_contacts=True)
    jobs = [Job(apply_model(tuple(Setting(p.kind, p.target, float(v)) for p, v in zip(parameters, row)), rollout,
                            odb, strict=False), replay) for row in draws]
    finals, facts, failures = [], [], []
    stopped = None
    outcomes = executor.iterate(jobs)
    try:
        for outcome in outcomes:
            if outcome.failed:
                finals.append(None)
                facts.append(None)
                failures.append(outcome.failure)
            else:
                r = outcome.result
                inferred = infer_state(world, odb, r.final_poses, r.final_contacts, r.moved, r.contact_pairs(),
                                       time=r.sim_time)
                finals.append(r.final_poses)
                facts.append(inferred.world.facts)
            if sample_progress is not None:
                sample_progress(len(facts), samples)
            if len(facts) < samples and any(f is not None for f in facts) and limit.expired():
                stopped = STOPPED
                break
    finally:
        outcomes.close()  # cancels the samples not started
    probabilities = fact_probabilities(facts, nominal.inference.world.facts)
    return SampledSession(nominal, parameters, draws[:len(facts)], tuple(finals), tuple(facts), tuple(failures),
                          probabilities,
                          with_probabilities(nominal.inference.world, probabilities, sum(f is not None for f in facts)),
                          requested=samples, stopped=stopped, time_limit=limit.seconds)


def fact_probabilities(facts: Sequence[frozenset[Fact] | None], nominal: frozenset[Fact]) -> dict[Fact, float]:
    """Each fact's share of the successful samples (every fact of the nominal state listed, at 0 if need be)."""
    ok = [f for f in facts if f is not None]
    if not ok:
        raise BridgeError(f"every one of the {len(facts)} sampled replays failed: no probability can be given")
    counts = Counter(fact for sample in ok for fact in sample)
    return {fact: counts.get(fact, 0) / len(ok) for fact in set(counts) | set(nominal)}


def with_probabilities(world: WorldState, probabilities: dict[Fact, float], samples: int) -> WorldState:
    """`world` (the nominal state) with the probabilities of the facts the samples did not all agree with."""
    disputed = {f: p for f, p in probabilities.items() if 0.0 < p < 1.0 or (p == 1.0) != (f in world.facts)}
    return replace(world, probabilities={**world.probabilities, **disputed},
                   samples=samples if disputed or world.probabilities else 0)


def spread_text(session: SampledSession) -> str:
    """A few lines for the terminal: what was drawn, how many samples, failures."""
    lines = [f"{len(session.facts)} samples ({METHOD}): {session.samples} replayed"
             + (f", {len(session.failures)} failed (first: {session.failures[0]})" if session.failures else "")]
    if session.stopped:
        lines.append(f"  partial: the time limit of {session.time_limit:g} s stopped the sampling after "
                     f"{len(session.facts)} of {session.requested} samples; the probabilities and their intervals "
                     f"are over those {session.samples}")
    if session.parameters:
        lines.append("  drawn: " + ", ".join(f"{p.name} {p.mean:.4g} +- {p.sd:.2g}" for p in session.parameters)
                     + f" (from {', '.join(dict.fromkeys(p.source for p in session.parameters))})")
    else:
        lines.append("  drawn: nothing (no parameter has an uncertainty here): every sample is the nominal replay")
    certain = sum(1 for p in session.probabilities.values() if p in (0.0, 1.0))
    lines.append(f"  {certain} fact(s) held in every sample or none, {len(session.probabilities) - certain} in some")
    return "\n".join(lines)


def probability_event(session: SampledSession) -> dict:
    """The closing line of `bridge infer --events --samples N`: every disputed fact's share and interval."""
    n = session.samples
    return {"t": round(session.nominal.replay.sim_time, 3), "final": True, "samples": n,
            **({"requested": session.requested, "stopped": session.stopped} if session.stopped else {}),
            "probabilities": {
        str(f): {"p": round(p, 4), "interval": [round(v, 4) for v in wilson_interval(p, n)]}
        for f, p in sorted(session.world.probabilities.items())}}


__all__ = ["METHOD", "SampledSession", "Uncertain", "default_parameters", "draw", "fact_probabilities",
           "parameters_from_file", "probability_event", "sample_session", "spread_text", "with_probabilities"]
