"""Fitting simulation parameters to recordings (the paper's Section V); see docs/fit.md.

trials.py      recordings (folders, MIT h5 pushes) prepared for fitting: `Trial`, `load_trials`
params.py      parameter files and the registry of parameter kinds (`PARAMETER_KINDS`, `register_kind`)
error.py       the paper's pose error, eq. (1)-(4)
rollout.py     replay trials with parameter values and score them (`evaluate`), cached diagrams per process
executors.py   where a generation's simulations run: serial, process pool, dask
optimizers/    the paper's (mu/rho + lambda)-ES and CMA-ES behind one ask/tell interface
fit.py         the driver: hold-out, early stop, checkpoints (`fit_parameters`)
report.py      params.yaml, fit.json, Table I, Fig. 4, real vs simulated paths
synthetic.py   recordings made with known parameters: recovery problems for tests and benchmarks
"""
