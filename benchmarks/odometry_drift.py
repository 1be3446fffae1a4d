"""Dead-reckoning drift of every synthetic preset's odometry (the realistic odometry).

For each preset and seed, the measured odometry (``datasets.synthetic.simulate.drive``: the
robot's systematic bias, then the thesis's alpha noise) is integrated from the true start pose
and compared with the true route, with no world and no rendering:

- drift: the mean relative translation error over segments of 10 m of true travel (half the
  route when it is shorter), as a percentage of the segment (KITTI's translational error; RPE in
  metres, ``metrics.trajectory.rpe``);
- end: the final position error as a percentage of the whole route;
- ATE: dead reckoning's SE(2)-aligned RMSE, what the reports show for it.

Run:  .venv/bin/python benchmarks/odometry_drift.py [--seeds 0 1 2] [--no-bias]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

import numpy as np

from omnislam.core.se import se2_integrate
from omnislam.core.types import Trajectory
from omnislam.datasets.synthetic.presets import PRESETS, Preset
from omnislam.datasets.synthetic.routes import NO_BIAS
from omnislam.datasets.synthetic.simulate import drive
from omnislam.metrics.trajectory import Alignment, accumulated_distances, ate, translational_drift

SEGMENT_M = 10.0


@dataclasses.dataclass(frozen=True, slots=True)
class Drift:
    """Dead-reckoning drift of one preset and seed."""

    length_m: float
    segment_m: float
    drift_pct: float
    end_pct: float
    ate_m: float


def dead_reckoning_drift(preset: Preset, seed: int) -> Drift:
    """Drift figures of ``preset``'s odometry for ``seed`` (see the module docstring)."""
    route = drive(preset, seed)
    dr = se2_integrate(route.odometry_r, route.poses_w[0])
    truth = Trajectory.from_se2(route.stamps_s, route.poses_w)
    estimate = Trajectory.from_se2(route.stamps_s, dr)
    length = float(accumulated_distances(route.poses_w[:, :2])[-1])
    drift, segment = translational_drift(estimate, truth, SEGMENT_M)
    end = float(np.hypot(*(dr[-1, :2] - route.poses_w[-1, :2])))
    return Drift(
        length_m=length,
        segment_m=segment,
        drift_pct=100 * drift,
        end_pct=100 * end / length,
        ate_m=ate(estimate, truth, Alignment.SE2).rmse_m,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--no-bias", action="store_true", help="alpha noise only, no bias")
    args = parser.parse_args()
    print(f"| preset | route [m] | drift per {SEGMENT_M:g} m (half the route if shorter) [%] "
          "| end error [% of route] "
          "| DR ATE (SE2) [m] |")
    print("|---|---|---|---|---|")
    for preset in PRESETS.values():
        if args.no_bias:
            preset = dataclasses.replace(preset, odometry_bias=NO_BIAS)
        print(
            f"{preset.name}: driving the route, seeds {' '.join(map(str, args.seeds))} ...",
            file=sys.stderr,
            flush=True,
        )
        rows = [dead_reckoning_drift(preset, s) for s in args.seeds]

        def span(values: list[float], fmt: str) -> str:
            lo, hi = min(values), max(values)
            return f"{lo:{fmt}}-{hi:{fmt}}" if len(values) > 1 else f"{lo:{fmt}}"

        print(f"| `{preset.name}` | {rows[0].length_m:.0f} | "
              f"{span([r.drift_pct for r in rows], '.1f')} | "
              f"{span([r.end_pct for r in rows], '.1f')} | "
              f"{span([r.ate_m for r in rows], '.2f')} |")


if __name__ == "__main__":
    main()
