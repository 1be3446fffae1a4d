"""Every dataset's odometry noise by one procedure: the thesis's alphas by maximum likelihood.

``omnislam.datasets.odometry_noise`` describes the procedure (windows of odometry against the
ground truth's motion, long enough for the ground truth's noise to be at most 10 % of the
residual's variance, on the first quarter of each recording; standard errors from the Fisher
information; residual statistics under the fit). This script applies it to each dataset and
prints one table. The ground truth's per-sample noise, the procedure's one input besides the
data, comes from:

* MR.CLAM (robots 1-5): the Vicon stream as recorded (``RobotN_Groundtruth.dat``, ~60 Hz), by
  its second differences (``second_difference_noise``);
* Victoria Park: the GPS stream as recorded (``gps.dat``, 5 Hz), the same way (positions only:
  the car's own acceleration adds to it, so it errs large); windows are compared by their shapes;
* CARMEN intel / aces: the corrected poses state no accuracy; ``CARMEN_POSE_NOISE`` is assumed
  (a scan matcher's registration error) -- the window rule makes the fit depend on it only
  through which windows are long enough;
* the thesis presets: exact (a control: the simulated alphas are known);
* gtsam's ``victoria_park.txt``: no ground truth; the file states its odometry noise, printed
  as stated.

Run::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/odometry_noise.py
        [--datasets mrclam6-r1 carmen-intel ...] [--fraction 0.25] [--share 0.1]
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

from omnislam.datasets.odometry_noise import (
    ALPHAS,
    FitConfig,
    GroundTruthNoise,
    OdometryNoiseFit,
    fit_odometry_noise,
    second_difference_noise,
)
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.datasets.sequence import Sequence
from omnislam.errors import OmnislamError

#: the corrected CARMEN poses' assumed per-sample noise: 1 cm and 0.3 deg (their SLAM system
#: registered each scan to a map; no accuracy is stated with the logs)
CARMEN_POSE_NOISE = GroundTruthNoise(0.01, float(np.radians(0.3)),
                                     "assumed: corrected poses state no accuracy")
#: the synthetic presets fitted as a control (their true alphas are in the preset)
SYNTHETIC = ("thesis-route1",)
DATASETS = (*(f"mrclam6-r{r}" for r in range(1, 6)), "victoria-park", "carmen-intel",
            "carmen-aces", "victoria-park-gtsam", *SYNTHETIC)


def ground_truth_noise(name: str) -> GroundTruthNoise:
    """The per-sample noise of ``name``'s ground truth (module docstring)."""
    if name in SYNTHETIC:
        return GroundTruthNoise(0.0, 0.0, "exact (simulated)")
    path = resolve(name).path
    if name.startswith("mrclam6-r"):
        robot = name.removeprefix("mrclam6-r")
        data = np.loadtxt(path / f"Robot{robot}_Groundtruth.dat", comments="#")
        return second_difference_noise(data[:, 0], data[:, 1:4], True, "Vicon")
    if name == "victoria-park":
        data = np.loadtxt(path / "gps.dat")
        return second_difference_noise(data[:, 0], data[:, 1:3], False, "GPS")
    if name.startswith("carmen-"):
        return CARMEN_POSE_NOISE
    raise OmnislamError(f"no ground-truth noise statement for {name}")


def synthetic_sequence(preset_name: str, seed: int = 0) -> tuple[Sequence, str]:
    """A preset's drive (odometry and true poses; no world, no sensors) as a Sequence, and its
    true alphas for the table."""
    from omnislam.core.types import Trajectory
    from omnislam.datasets.sequence import GroundTruth, GroundTruthKind
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import drive

    preset = PRESETS[preset_name]
    route = drive(preset, seed)
    truth = Trajectory.from_se2(route.stamps_s, route.poses_w)
    sequence = Sequence(name=f"{preset_name} s{seed}", source="simulated drive",
                        stamps_s=route.stamps_s, odometry_r=route.odometry_r,
                        ground_truth=GroundTruth(kind=GroundTruthKind.EXACT, trajectory=truth))
    true = ", ".join(f"{getattr(preset.motion_noise, a):g}" for a in ALPHAS)
    return sequence, f"true ({true})"


def stated_noise(sequence: Sequence) -> str:
    """The median stated odometry stds (x, y, theta) of a dataset that states them."""
    covariance = sequence.odometry_covariance_r
    if covariance is None:
        return "states no odometry noise"
    sigmas = np.median(np.sqrt(np.einsum("kii->ki", covariance[1:])), axis=0)
    return ("stated per step: sigma x, y, theta = "
            f"{sigmas[0]:.3g} m, {sigmas[1]:.3g} m, {sigmas[2]:.3g} rad (median)")


def row(name: str, fit: OdometryNoiseFit, note: str) -> list[str]:
    """One table row: the fit and its diagnostics."""
    alphas = [f"{a:.4f} ± {e:.4f}" for a, e in zip(fit.alphas, fit.standard_errors, strict=True)]
    res = fit.residuals
    z = ", ".join(f"{c} {m:+.2f}/{s:.2f}" for c, m, s in
                  zip(res.components, res.mean, res.std, strict=True))
    gt = fit.ground_truth
    heading = "-" if gt.sigma_heading_rad is None else f"{gt.sigma_heading_rad:.2g} rad"
    return [
        name, *alphas,
        f"{fit.windows} ({fit.window_length_m:.2f} m, {fit.window_duration_s:.1f} s, "
        f"{fit.window_steps:.0f} steps)",
        f"{gt.sigma_position_m:.2g} m, {heading} [{gt.source}]",
        "/".join(f"{100 * s:.0f}" for s in fit.ground_truth_share) + " %",
        z, f"{res.nees_mean:.2f}", f"{100 * res.beyond_99:.1f} %", note,
    ]


HEADER = ["dataset", *ALPHAS, "windows (median length, duration, steps)",
          "ground-truth noise", "GT share x/y/th", "z mean/std per component",
          "NEES mean (3)", "> chi2 99 % (1 %)", "note"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--datasets", nargs="+", default=list(DATASETS))
    defaults = FitConfig()
    parser.add_argument("--fraction", type=float, default=defaults.fraction)
    parser.add_argument("--share", type=float, default=defaults.max_ground_truth_share)
    args = parser.parse_args(argv)
    config = FitConfig(fraction=args.fraction, max_ground_truth_share=args.share)
    rows = []
    for name in args.datasets:
        print(f"{name} ...", file=sys.stderr, flush=True)
        try:
            if name in SYNTHETIC:
                sequence, note = synthetic_sequence(name)
            else:
                sequence, note = load_dataset(name), ""
            if sequence.ground_truth.trajectory is None:
                rows.append([name, *["-"] * (len(HEADER) - 2), stated_noise(sequence)])
                continue
            gt = ground_truth_noise(name)
            rows.append(row(name, fit_odometry_noise(sequence, gt, config), note))
        except OmnislamError as exc:
            rows.append([name, *["-"] * (len(HEADER) - 2), f"no fit: {exc}"])
    print(_markdown(HEADER, rows))
    command = " ".join(shlex.quote(a) for a in [f"benchmarks/{Path(__file__).name}",
                                                *(argv if argv is not None else sys.argv[1:])])
    print(f"\nfraction {config.fraction}, share {config.max_ground_truth_share}, "
          f"min window {config.min_window_s} s, sizes over {config.size_window_s} s; "
          f"command: PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python {command}")
    return 0


def _markdown(header: list[str], rows: list[list[str]]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
