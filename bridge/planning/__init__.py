"""PDDL planning: action templates, the domain and problem of a world state, and the action applier.

Uses the `pddl` library for parsing and printing; everything it leaves unchecked is checked against the object
database here. Fast Downward and VAL (the ``planners`` extra) are run by `planner.py` when installed.
"""
from .apply import PlanStep, apply_action, apply_plan, goal_holds, read_plan, unmet_goal
from .domain import build_domain, domain_text
from .problem import ProblemFacts, build_problem, export_pddl, problem_text, read_problem
from .templates import ActionTemplate, DomainSettings, load_action_template, load_action_templates, load_domain_settings

__all__ = [
    "ActionTemplate", "DomainSettings", "PlanStep", "ProblemFacts", "apply_action", "apply_plan", "build_domain",
    "build_problem", "domain_text", "export_pddl", "goal_holds", "load_action_template", "load_action_templates",
    "load_domain_settings", "problem_text", "read_plan", "read_problem", "unmet_goal",
]
