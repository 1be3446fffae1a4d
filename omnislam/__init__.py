"""omnislam: compare SLAM back ends on one shared omnidirectional front end.

Subpackages (imports flow one way): ``core`` <- ``camera`` <- ``datasets``, ``frontend``
<- estimators (``graphslam``, ``fastslam``, ``ukf``, ``ekfslam``) <- ``metrics`` <- ``harness``
<- ``report`` <- ``demo`` <- ``cli``.

The public Python API, for notebooks and scripts: thin names over the functions the command
line itself calls, so a script and ``omnislam run`` / ``compare`` / ``report`` give the same
numbers. Each is imported on first use (``import omnislam`` stays light); ``examples/api.py``
does the whole round trip.

Data and front end:
    ``load_dataset(name_or_path, options)`` -> ``Sequence`` (``datasets.registry``);
    ``run_frontend(sequence, config)`` -> ``ObservationLog`` and ``save_observation_log(log,
    path)`` (``frontend``): the shared front end's observations.
Estimators:
    ``registered_estimators()`` -> name -> ``EstimatorEntry`` (the built-ins and the installed
    plugins, ``omnislam.estimators``); ``fed_frames(sequence, name, log)`` -> the frames and the
    ``SequenceInfo`` an estimator is fed (``harness.frames``); ``make_estimator(name, info,
    options, rng)`` -> an object with ``step(frame)`` and ``estimate()``.
Runs, as ``omnislam run``:
    ``execute_run(RunSpec(dataset, estimator, seed, options))`` -> ``RunRecord`` (the run
    through the registry, timed); ``write_run_dir(path, record)`` / ``read_run_dir(path)``.
Evaluation:
    ``evaluate_run(record, EvaluationOptions())`` -> ``RunMetrics`` (every metric of
    ``omnislam evaluate``); ``ate(estimate, truth, Alignment.SE2)`` and ``rpe(...)`` on two
    ``Trajectory`` objects (``metrics.trajectory``).
Comparisons and reports, as ``omnislam compare`` and ``omnislam report``:
    ``load_grid(path)`` -> ``Grid``; ``run_grid(grid, out_dir, executor_factory)`` ->
    ``GridResult`` (``SerialExecutor`` runs in this process); ``write_report(results_dir,
    out_dir, ReportOptions())``.

Example::

    import omnislam as om

    record = om.execute_run(om.RunSpec("mrclam6-r1", "ekfslam", seed=0))
    print(om.evaluate_run(record).ate.rmse_m)
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from omnislam._version import __version__

if TYPE_CHECKING:  # what the lazy names are, for type checkers and editors
    from omnislam.datasets.registry import load_dataset
    from omnislam.estimators import EstimatorEntry, make_estimator
    from omnislam.frontend.observation_log import save_observation_log
    from omnislam.frontend.pipeline import run_frontend
    from omnislam.harness.evaluation import EvaluationOptions, evaluate_run
    from omnislam.harness.execute import RunSpec, execute_run
    from omnislam.harness.frames import fed_frames
    from omnislam.harness.grid import load_grid
    from omnislam.harness.rundir import read_run_dir, write_run_dir
    from omnislam.harness.runner import SerialExecutor, run_grid
    from omnislam.metrics.trajectory import Alignment, ate, rpe
    from omnislam.report.comparison import write_report
    from omnislam.report.options import ReportOptions

#: public name -> the module that defines it
_PUBLIC = {
    "load_dataset": "omnislam.datasets.registry",
    "run_frontend": "omnislam.frontend.pipeline",
    "save_observation_log": "omnislam.frontend.observation_log",
    "EstimatorEntry": "omnislam.estimators",
    "make_estimator": "omnislam.estimators",
    "fed_frames": "omnislam.harness.frames",
    "RunSpec": "omnislam.harness.execute",
    "execute_run": "omnislam.harness.execute",
    "write_run_dir": "omnislam.harness.rundir",
    "read_run_dir": "omnislam.harness.rundir",
    "EvaluationOptions": "omnislam.harness.evaluation",
    "evaluate_run": "omnislam.harness.evaluation",
    "Alignment": "omnislam.metrics.trajectory",
    "ate": "omnislam.metrics.trajectory",
    "rpe": "omnislam.metrics.trajectory",
    "load_grid": "omnislam.harness.grid",
    "run_grid": "omnislam.harness.runner",
    "SerialExecutor": "omnislam.harness.runner",
    "write_report": "omnislam.report.comparison",
    "ReportOptions": "omnislam.report.options",
}

__all__ = [
    "Alignment",
    "EstimatorEntry",
    "EvaluationOptions",
    "ReportOptions",
    "RunSpec",
    "SerialExecutor",
    "__version__",
    "ate",
    "evaluate_run",
    "execute_run",
    "fed_frames",
    "load_dataset",
    "load_grid",
    "make_estimator",
    "read_run_dir",
    "registered_estimators",
    "rpe",
    "run_frontend",
    "run_grid",
    "save_observation_log",
    "write_report",
    "write_run_dir",
]


def registered_estimators() -> dict[str, EstimatorEntry]:
    """Every registered estimator, name -> ``EstimatorEntry``: the built-ins, then the installed
    plugins (``omnislam.estimators.registry``; a copy, so changing it changes nothing)."""
    from omnislam.estimators import registry

    return dict(registry().entries)


def __getattr__(name: str) -> object:
    """Import a public name's module on first use (PEP 562) and keep the name here."""
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'omnislam' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_PUBLIC})
