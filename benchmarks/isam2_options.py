"""What grows in iSAM2's update on an omni log, and what GTSAM's options do about it.

Replays a cached front-end log (as ``realtime_lab40.py`` does) through ``graphslam`` with
iSAM2 over the whole graph (``solver.online_lag_key_frames=none``), once per configuration, and for
every key-frame update records the CPU time of ``ISAM2.update`` and its ``ISAM2Result``:
variables re-eliminated and relinearised, and the Bayes tree's non-zeros. Prints, per
configuration, the run's CPU time, ATE, the per-image flatness (95th percentile of the image
steps' CPU time over images 100-200 and the last 100, as ``realtime_lab40.py``) and the median
re-eliminated / relinearised variables of the last 20 updates; with ``--growth``, the defaults'
updates in eight blocks.

Configurations: ``--set KEY=VALUE`` options of ``GraphSLAMConfig``
(``solver.relinearize_threshold``, ``solver.relinearize_skip``,
``solver.adaptive_reorder_threshold``), and ``P:NAME=VALUE`` for an ``ISAM2Params`` attribute
the config does not expose (``cacheLinearizedFactors``, ``findUnusedFactorSlots``)::

    PYTHONPATH=. .venv/bin/python benchmarks/isam2_options.py lab40 runs/lab40-v2 LOG \\
        --growth --config "" --config solver.relinearize_threshold=0.5 \\
        --config solver.relinearize_skip=10 --config solver.adaptive_reorder_threshold=2 \\
        --config P:cacheLinearizedFactors=False \\
        --config P:findUnusedFactorSlots=True
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import realtime_lab40 as rt
from harness_cells import set_options

from omnislam.core.types import Trajectory
from omnislam.estimators import make_estimator
from omnislam.graphslam import session as session_module
from omnislam.metrics.trajectory import ate


class _Recorder:
    """Wraps ``ISAM2Session`` construction and update to read GTSAM's own results."""

    def __init__(self, params: dict[str, str]) -> None:
        self.params = params
        self.updates: list[tuple[int, float, int, int, int]] = []

    def install(self) -> None:
        recorder = self
        cls = session_module.ISAM2Session
        new_isam = cls._new_isam

        def _new_isam(self, factorization):
            isam = new_isam(self, factorization)
            if not recorder.params:
                return isam
            params = isam.params()
            for name, text in recorder.params.items():
                setattr(params, name, type(getattr(params, name))(eval(text)))
            return session_module.gtsam.ISAM2(params)

        def update(self, graph, values, frame_index):
            self._pose3_cache.clear()
            start = time.process_time()
            result = self._isam.update(graph, values)
            recorder.updates.append(
                (
                    frame_index,
                    time.process_time() - start,
                    int(result.getVariablesReeliminated()),
                    int(result.getVariablesRelinearized()),
                    int(self._isam.treeNnz()),
                )
            )
            self._all_factors.push_back(graph)

        cls._new_isam = _new_isam
        cls.update = update


def run(data: rt.Replay, options: dict[str, str], params: dict[str, str], growth: bool) -> None:
    recorder = _Recorder(params)
    recorder.install()
    options = {"solver.online_lag_key_frames": "none", **options}
    estimator = make_estimator("graphslam", data.info, options, np.random.default_rng(0))
    cpu = np.zeros(len(data.frames))
    start = time.process_time()
    for i, frame in enumerate(data.frames):
        step = time.process_time()
        estimator.step(frame)
        cpu[i] = time.process_time() - step
    estimate = estimator.estimate()
    total = time.process_time() - start
    truth = data.truth.trajectory
    keep = np.isin(truth.stamps_s, estimate.trajectory.stamps_s)
    error = ate(estimate.trajectory, Trajectory(truth.stamps_s[keep], truth.poses_w[keep]))
    image = cpu[data.images]
    early, late = (np.percentile(w, 95) * 1e3 for w in (image[rt.EARLY], image[-rt.LATE :]))
    table = np.array(recorder.updates, dtype=float)
    settings = {**options, **{f"P:{k}": v for k, v in params.items()}}
    label = " ".join(f"{k}={v}" for k, v in settings.items()) or "defaults"
    print(
        f"{label:60s} CPU {total:6.2f} s  ATE {error.rmse_m * 100:5.2f} cm  "
        f"p95 {early:5.1f} / {late:5.1f} ms = {late / early:4.2f}x  last 20 updates: "
        f"re-eliminated {np.median(table[-20:, 2]):.0f}, relinearised "
        f"{np.median(table[-20:, 3]):.0f}",
        flush=True,
    )
    if growth:
        n = len(table)
        for lo in range(0, n, max(n // 8, 1)):
            block = table[lo : lo + max(n // 8, 1)]
            print(
                f"  updates {lo:4d}-{lo + len(block):4d} (from frame {int(block[0, 0]):5d}): "
                f"update median {np.median(block[:, 1]) * 1e3:6.1f} ms, p95 "
                f"{np.percentile(block[:, 1], 95) * 1e3:6.1f} ms, re-eliminated "
                f"{np.median(block[:, 2]):4.0f}, relinearised {np.median(block[:, 3]):3.0f}, "
                f"tree non-zeros {int(block[-1, 4])}"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name")
    parser.add_argument("folder")
    parser.add_argument("log")
    parser.add_argument(
        "--config",
        action="append",
        default=None,
        help='space-separated KEY=VALUE / P:NAME=VALUE (repeatable; "" = the defaults)',
    )
    parser.add_argument("--growth", action="store_true", help="the defaults' updates in blocks")
    args = parser.parse_args()
    configs = [set_options(parser, text.split(), "--config") for text in args.config or [""]]
    data = rt.prepare(args.name, args.folder, args.log, None)
    original = (session_module.ISAM2Session._new_isam, session_module.ISAM2Session.update)
    for i, config in enumerate(configs):
        items = config.items()
        options = {k: v for k, v in items if not k.startswith("P:")}
        params = {k[2:]: v for k, v in items if k.startswith("P:")}
        shown = " ".join(f"{k}={v}" for k, v in items) or "the defaults"
        print(f"{args.name}: running graphslam with {shown} ...", file=sys.stderr, flush=True)
        run(data, options, params, args.growth and i == 0)
        session_module.ISAM2Session._new_isam, session_module.ISAM2Session.update = original


if __name__ == "__main__":
    main()
