"""The rollout layer: what is simulated, where, and how it is compared with what was observed. Fitting,
diagnosis, the proof and `bridge infer` all simulate through it.

rollout.py    `Rollout` (world, scene values, telemetry, extras, hooks, settings), the scene cache, `run_rollout`
executors.py  serial / process pool / dask: `Executor.run(jobs) -> outcomes`
compare.py    pose interpolation, residuals, the paper's error (eq. 1-4), least-squares vectors
trials.py     recordings prepared for comparison (`Trial`, `load_trials`)
limit_surface.py  the analytical baseline of quasi-static planar pushing (ellipsoidal limit surface), no Drake
"""
from .compare import DEFAULT_C, PoseError, error_of_residuals, observed_residuals, pose_residual, sample_track
from .executors import Executor, make_executor
from .rollout import Job, Outcome, Rollout, run_job, run_rollout, scene_for
from .trials import Trial, load_trials

__all__ = ["DEFAULT_C", "Executor", "Job", "Outcome", "PoseError", "Rollout", "Trial", "error_of_residuals",
           "load_trials", "make_executor", "observed_residuals", "pose_residual", "run_job", "run_rollout",
           "sample_track", "scene_for"]
