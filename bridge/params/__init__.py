"""One vocabulary of parameters for fitting, diagnosis and replay.

kinds.py       parameter kinds: how one value changes a rollout (`KINDS`, spelled out in one place)
model.py       `Setting` (a value of a kind on a target), models (tuples of settings), `apply_model`
parameters.py  `Parameter`, `ParameterSet`: free and fixed entries, the optimisers' coordinates
files.py       parameter files (also the diagnosis' scene files): read, check, write
surfaces.py    which fixture carries which object (for kinds and effects)
"""
from .files import load_param_file, param_file_text, parse_params, save_param_file
from .kinds import KINDS, Family, Kind, kind_named, register_kind
from .model import Model, Setting, apply_model, canonical_model, trial_rollout
from .parameters import Parameter, ParameterSet, check_targets, check_values, replay_model

__all__ = ["KINDS", "Family", "Kind", "Model", "Parameter", "ParameterSet", "Setting", "apply_model", "canonical_model", "check_targets",
           "check_values", "kind_named", "load_param_file", "param_file_text", "parse_params", "register_kind",
           "replay_model", "save_param_file", "trial_rollout"]
