"""Fitting simulation parameters to recordings (the paper's Section V); see docs/fit.md.

evaluate.py    a fit's objective: trials replayed under parameter values (bridge.rollout), the paper's error,
               the ordinary parameters fitted by default (`default_spec`)
fit.py         the driver: hold-out, optimisers (bridge.optim: ES, CMA-ES, Levenberg-Marquardt), early stop,
               checkpoints (`fit_parameters`)
report.py      params.yaml, fit.json, Table I, Fig. 4, real vs simulated paths
synthetic.py   recordings made with known parameters: recovery problems for tests and benchmarks

Parameters and parameter files are `bridge.params`; trials and executors are `bridge.rollout`.
"""
