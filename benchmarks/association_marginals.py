"""What the unknown-association's joint marginal costs graphslam, and where that cost comes from.

On Victoria Park (no landmark ids) graphslam spends most of its time in one call per frame:
``ISAM2Session.joint_marginal_covariance``, iSAM2's joint marginal of the newest key pose and the
candidate landmarks that the window association (``graphslam/window_association.py``) gives to
JCBB. This script runs ``graphslam`` through the harness, as

    omnislam run DATASET --estimator graphslam --seed 0 [--set key=value ...]

does, with hooks (in this process only) on that call and on ``ISAM2Session.update``, and prints:

* the CPU time of the run (loading the dataset included, the probes below left out), of the
  joint queries and of the iSAM2 updates;
* the joint query's mean cost per quarter of the calls (how it grows with the map), and by the
  number of keys queried;
* every ``--probe-every``-th call, the same keys again one by one (``ISAM2.marginalCovariance``
  of each): the newest pose's own marginal, the median and the largest of the candidate
  landmarks' -- whether the joint query costs what its deepest candidate costs (a landmark's
  marginal is a walk from its Bayes-tree clique to the root, which every update replaces, so no
  shortcut survives from one frame to the next) or what its number of keys costs.

``--stop-after N`` ends the run after N joint queries (the summary is printed, no run folder is
written): a long run's first part shows the trend in a fraction of the time.

::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/association_marginals.py
        [victoria-park] [--set key=value ...] [--probe-every 50] [--stop-after N]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from harness_cells import set_options

from omnislam._progress import Stages
from omnislam.graphslam import session as graph_session
from omnislam.harness.execute import RunSpec, execute_run


class _StopError(Exception):
    """Raised by the hook after ``--stop-after`` joint queries."""


class _Recorder:
    """The hooks on ``ISAM2Session``: joint queries (keys, CPU s), updates, and probes."""

    def __init__(self, probe_every: int, stop_after: int | None) -> None:
        self.calls: list[tuple[int, float]] = []
        self.updates: list[float] = []
        # per probe [ms]: joint, the pose alone, the median, largest and sum of the landmarks
        self.probes: list[tuple[float, float, float, float, float]] = []
        self.probe_s = 0.0  # CPU spent probing, left out of the run's CPU
        self.probe_every = probe_every
        self.stop_after = stop_after

    def install(self) -> None:
        cls = graph_session.ISAM2Session
        joint, update = cls.joint_marginal_covariance, cls.update
        recorder = self

        def timed_joint(session, keys):
            t = time.process_time()
            covariance = joint(session, keys)
            recorder.calls.append((len(keys), time.process_time() - t))
            every = recorder.probe_every
            if every and len(recorder.calls) % every == 0 and len(keys) > 1:
                recorder.probe(session, list(keys), recorder.calls[-1][1])
            if recorder.stop_after is not None and len(recorder.calls) >= recorder.stop_after:
                raise _StopError
            return covariance

        def timed_update(session, *args, **kwargs):
            t = time.process_time()
            update(session, *args, **kwargs)
            recorder.updates.append(time.process_time() - t)

        cls.joint_marginal_covariance = timed_joint
        cls.update = timed_update

    def probe(self, session, keys: list[int], joint_s: float) -> None:
        """Each key's own marginal, timed (the first key is the newest pose)."""
        start = time.process_time()
        single = []
        for key in keys:
            t = time.process_time()
            session.marginal_covariance(key)
            single.append(time.process_time() - t)
        landmarks = np.array(single[1:]) * 1e3
        self.probes.append(
            (
                joint_s * 1e3,
                single[0] * 1e3,
                float(np.median(landmarks)),
                float(landmarks.max()),
                float(landmarks.sum()),
            )
        )
        self.probe_s += time.process_time() - start


def _report(recorder: _Recorder, run_cpu_s: float, stopped: bool) -> None:
    calls = np.array(recorder.calls).reshape(-1, 2)
    n = len(calls)
    joint_s, update_s = calls[:, 1].sum(), float(np.sum(recorder.updates))
    print(
        f"{'stopped after' if stopped else 'whole run:'} {n} joint queries; CPU {run_cpu_s:.1f} s, "
        f"of which joint queries {joint_s:.1f} s ({joint_s / run_cpu_s:.0%}), iSAM2 updates "
        f"{update_s:.1f} s ({update_s / run_cpu_s:.0%})"
    )
    if not n:
        return
    print(f"keys per query: mean {calls[:, 0].mean():.1f}, largest {calls[:, 0].max():.0f}")
    quarters = np.array_split(np.arange(n), 4)
    print(
        "ms per query, by quarter of the queries: "
        + ", ".join(f"{1e3 * calls[q, 1].mean():.1f}" for q in quarters if len(q))
    )
    for lo, hi in ((1, 3), (3, 6), (6, 10), (10, 20), (20, 10**6)):
        sel = (calls[:, 0] >= lo) & (calls[:, 0] < hi)
        if sel.any():
            label = f"{lo}-{hi - 1}" if hi < 10**6 else f">= {lo}"
            print(
                f"  {label:>6} keys: {int(sel.sum()):5d} queries, "
                f"{1e3 * calls[sel, 1].mean():7.1f} "
                f"ms each, {calls[sel, 1].sum():7.1f} s"
            )
    if recorder.probes:
        p = np.array(recorder.probes)
        print(
            f"probes ({len(p)}, every {recorder.probe_every}th query; medians over probes, ms): "
            f"joint {np.median(p[:, 0]):.1f}, the pose alone {np.median(p[:, 1]):.2f}, "
            f"a landmark alone {np.median(p[:, 2]):.1f}, the costliest landmark alone "
            f"{np.median(p[:, 3]):.1f}, all landmarks one by one {np.median(p[:, 4]):.1f}; "
            f"joint / costliest landmark {np.median(p[:, 0] / np.maximum(p[:, 3], 1e-3)):.2f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", nargs="?", default="victoria-park")
    parser.add_argument("--set", dest="options", action="append", default=[], metavar="K=V")
    parser.add_argument("--probe-every", type=int, default=50)
    parser.add_argument("--stop-after", type=int, default=None)
    args = parser.parse_args()
    options = set_options(parser, args.options)
    recorder = _Recorder(args.probe_every, args.stop_after)
    recorder.install()
    print(f"graphslam on {args.dataset} {options or ''}", flush=True)
    t = time.process_time()
    stopped = False
    with Stages(f"graphslam on {args.dataset}") as stages:
        try:
            execute_run(RunSpec(args.dataset, "graphslam", 0, options), on_step=stages)
        except _StopError:
            stopped = True
    _report(recorder, time.process_time() - t - recorder.probe_s, stopped)


if __name__ == "__main__":
    main()
