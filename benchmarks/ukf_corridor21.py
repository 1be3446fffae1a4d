"""The vertical-line UKF on corridor21 (Barra & Costa's 21 m U corridor, pinhole camera).

Renders corridor21 with odometry noise 4x the preset's (so that dead reckoning is clearly
wrong), runs the shared front end (vertical lines), surveys the map's MC descriptors from the
frames at their true poses (the paper's hand-made map), then localises and reports: mean
position error of the UKF and of dead reckoning, ms per processed frame (steps 3-5 + update;
steps 1-2 are the front end's vertical-edge time, printed separately), and association quality
against the renderer's ground truth (lines labelled by their true projection within 4 px).

    PYTHONPATH=. python benchmarks/ukf_corridor21.py [--out DIR] [--noise 4] [--set k=v ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import time
import warnings
from pathlib import Path

import numpy as np

warnings.filterwarnings("ignore", category=UserWarning)


def main() -> None:
    from omnislam.core.modality import Modality
    from omnislam.core.se import se2_from_se3, se2_integrate
    from omnislam.datasets.synthetic.loader import load_synthetic
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic
    from omnislam.frontend.pipeline import cached_frontend
    from omnislam.options import apply_options
    from omnislam.ukf import UKFConfig, VerticalLineUKF
    from omnislam.ukf.image_line import image_line_from_rig
    from omnislam.ukf.survey import label_lines, survey_descriptors

    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="/tmp/ukf_bench")
    parser.add_argument("--noise", type=float, default=4.0, help="x the preset's alphas")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--set", nargs="*", default=["innovation_gate=0.999"])
    args = parser.parse_args()
    out = Path(args.out)
    folder = out / f"corridor21-noise{args.noise:g}-seed{args.seed}"
    preset = PRESETS["corridor21"]
    n = preset.motion_noise
    noise = dataclasses.replace(
        n,
        a_vv=n.a_vv * args.noise,
        a_vw=n.a_vw * args.noise,
        a_wv=n.a_wv * args.noise,
        a_ww=n.a_ww * args.noise,
    )
    if not folder.exists():
        sim = simulate(dataclasses.replace(preset, motion_noise=noise), args.seed)
        write_synthetic(folder, sim)
    seq = load_synthetic(folder)
    log = cached_frontend(seq, out / (folder.name + ".log.npz"))
    truth = se2_from_se3(seq.ground_truth.trajectory.poses_w)
    line = image_line_from_rig(seq.calibration)
    prior = survey_descriptors(seq.prior_map, log.frames, truth, line, tol_px=4.0)
    options = dict(kv.split("=", 1) for kv in args.set)
    config = apply_options(UKFConfig(motion_noise=noise), options)
    ukf = VerticalLineUKF(prior, config, Modality.VERTICAL_LINES, line)
    processed_s = []
    for frame in log.frames:
        start = time.perf_counter()
        ukf.step(frame)
        elapsed = time.perf_counter() - start
        if ukf.associations and ukf.associations[-1].index == frame.index:
            processed_s.append(elapsed)
    poses = ukf.estimate().trajectory.se2
    err = np.hypot(*(poses[:, :2] - truth[:, :2]).T)
    dr = se2_integrate(seq.odometry_r, seq.initial_pose_w)
    err_dr = np.hypot(*(dr[:, :2] - truth[:, :2]).T)
    pairs = wrong_pairs = used = wrong_used = seen = visible = 0
    for a in ukf.associations:
        labels = label_lines(truth[a.index], a.bearings_rad, prior, line, 4.0)
        seen += int((labels >= 0).sum())
        visible += len(a.candidates)
        pairs += len(a.pairs)
        wrong_pairs += sum(int(labels[i] != j) for i, j in a.pairs)
        used += len(a.used)
        wrong_used += sum(int(labels[i] != j) for i, j in a.used)
    k = len(ukf.associations)
    edges_s = (
        log.stats.get("seconds_vertical_edges", float("nan"))
        if hasattr(log, "stats")
        else float("nan")
    )
    print(f"data: {folder} (odometry noise x{args.noise:g}); options {options}")
    print(
        f"UKF mean position error {err.mean() * 100:.1f} cm (max {err.max() * 100:.1f});"
        f" dead reckoning {err_dr.mean() * 100:.1f} cm (max {err_dr.max() * 100:.1f});"
        f" ratio {err_dr.mean() / err.mean():.1f}x"
    )
    print(
        f"processed frames {k}; steps 3-5 + update median {np.median(processed_s) * 1e3:.2f} ms;"
        f" steps 1-2 (front end vertical edges) {edges_s / max(k, 1) * 1e3:.1f} ms per image"
    )
    print(
        f"per processed frame: candidates {visible / k:.1f}, lines labelled {seen / k:.1f},"
        f" step-4 pairs {pairs / k:.1f} ({wrong_pairs} of {pairs} wrong),"
        f" used {used / k:.2f} ({wrong_used} of {used} wrong = {wrong_used / max(used, 1):.1%})"
    )
    print(ukf.info())


if __name__ == "__main__":
    main()
