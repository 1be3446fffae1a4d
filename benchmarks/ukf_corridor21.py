"""The vertical-line UKF on corridor21 (Barra & Costa's 21 m U corridor, pinhole camera).

Renders corridor21 (``--noise`` times the preset's alpha noise on top of its systematic
odometry drift; 1, the default, is the preset's own odometry, dead reckoning 6-18 cm mean
error over seeds 0-4), runs the shared front end (vertical lines), takes the folder's prior map
(the world's line map with the MC descriptors surveyed while rendering, ``line_colours.csv``:
the paper's hand-made map, and what ``omnislam run`` gives the UKF), then localises with the
UKF's defaults (the noise of the data is not given to it) and reports: mean position error of
the UKF and of dead reckoning, time per processed frame (steps 3-5 and the update, CPU and
wall; steps 1-2 are the front end's vertical-edge time, printed separately), and association
quality against the renderer's ground truth (lines labelled by their true projection within
4 px).

``--seeds`` gives one row per seed. ``--dump-wrong`` (with ``--sweep``) lists every wrong
validated pair and what let it through. ``--ablation`` compares the defaults with the paper's
step 4 alone (no covariance gates, Sc_k alone), the covariance gates with Sc_k alone, the
defaults without the nearest-line rule, and the defaults with core's (4x smaller) odometry
noise. ``--sweep`` runs the paper's d_it sweep
(sec. 5: 10-90 cm) on the same render, front end and map, one table row per value. ``--sck``
runs the Sc_k calibration of sec. 5 ("first Sc_k was calibrated, to minimise the number of
incorrect associations"): the only free constant of Sc_k is the weight of F_shift
(``association.shift_weight``, paper 100), swept with d_it at its default; and for the chosen
weight, the Sc_k / F_shift / mean C'_ij of the step-4 sets that were entirely right against
those holding a wrong pair. ``--sck-min`` drops sets below an Sc_k threshold.

    PYTHONPATH=. python benchmarks/ukf_corridor21.py [--out DIR] [--noise 1] [--seed 0]
        [--set k=v ...] [--seeds S ...] [--ablation] [--sweep [CM ...]] [--sck [W ...]]
        [--sck-min [T ...]] [--image-every K] [--dump-wrong]

corridor21 renders one image every 12 odometry steps (about 36 cm of travel), so d_it below
that processes every image: the sweep renders with ``--image-every 3`` (about 9 cm). Renders and
front-end logs are kept in ``--out`` (default /tmp/ukf_corridor21) and reused; a folder
rendered before ``line_colours.csv`` existed is refused.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
import warnings
from pathlib import Path

import numpy as np
from harness_cells import set_options

warnings.filterwarnings("ignore", category=UserWarning)

#: the sweep's d_it values [cm] (paper sec. 5: 10-40 cm vary little, 40-90 cm deteriorate)
SWEEP_CM = (10.0, 20.0, 30.0, 37.5, 50.0, 70.0, 90.0)
#: weights of F_shift in Sc_k tried by --sck (paper: 100)
SCK_WEIGHTS = (0.0, 1.0, 10.0, 30.0, 100.0, 300.0, 1000.0, 1e6)
#: minimum Sc_k of a step-4 set tried by --sck-min (100.5: F_shift at its ceiling, sqrt(n_k))
SCK_THRESHOLDS = (0.0, 10.0, 30.0, 60.0, 100.5, 141.0)


@dataclasses.dataclass
class Setup:
    """What every run shares: data, front-end log, truth, 1-D image, surveyed map."""

    folder: Path
    seq: object
    log: object
    truth: np.ndarray
    line: object
    prior: object
    noise: object
    err_dr: np.ndarray


def prepare(out: Path, noise_factor: float, seed: int, image_every: int | None = None) -> Setup:
    """Render (once), front end (cached), the folder's prior map with its MC descriptors."""
    from omnislam.core.se import se2_from_se3, se2_integrate
    from omnislam.datasets.synthetic.loader import load_synthetic
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic
    from omnislam.frontend.pipeline import cached_frontend
    from omnislam.ukf.image_line import image_line_from_rig

    preset = PRESETS["corridor21"]
    tag = "" if image_every in (None, preset.image_every_k) else f"-img{image_every}"
    folder = out / f"corridor21-noise{noise_factor:g}-seed{seed}{tag}"
    if image_every is not None:
        preset = dataclasses.replace(preset, image_every_k=image_every)
    n = preset.motion_noise
    noise = dataclasses.replace(
        n,
        a_vv=n.a_vv * noise_factor,
        a_vw=n.a_vw * noise_factor,
        a_wv=n.a_wv * noise_factor,
        a_ww=n.a_ww * noise_factor,
    )
    if not folder.exists():
        sim = simulate(dataclasses.replace(preset, motion_noise=noise), seed)
        write_synthetic(folder, sim)
    seq = load_synthetic(folder)
    log = cached_frontend(seq, out / (folder.name + ".log.npz"))
    truth = se2_from_se3(seq.ground_truth.trajectory.poses_w)
    line = image_line_from_rig(seq.calibration)
    prior = seq.prior_map  # MC descriptors surveyed while rendering (line_colours.csv)
    if prior.means_left is None:
        raise SystemExit(f"{folder} has no line_colours.csv (an older render): remove it")
    dr = se2_integrate(seq.odometry_r, seq.initial_pose_w)
    err_dr = np.hypot(*(dr[:, :2] - truth[:, :2]).T)
    return Setup(folder, seq, log, truth, line, prior, noise, err_dr)


def run_once(
    setup: Setup, options: dict[str, str], spy_sets: bool = False, min_score: float | None = None
) -> dict:
    """One localisation; the numbers of a table row (and the step-4 sets when ``spy_sets``).

    ``min_score``: a step-4 set of smaller Sc_k is discarded (no pair this frame): the threshold
    reading of the paper's Sc_k calibration, applied here around ``associate_landmarks`` (the
    localiser has no such option).
    """
    import omnislam.ukf.localiser as localiser_module
    from omnislam.core.modality import Modality
    from omnislam.options import apply_options
    from omnislam.ukf import UKFConfig, VerticalLineUKF
    from omnislam.ukf.association import set_score
    from omnislam.ukf.survey import label_lines

    config = apply_options(UKFConfig(), options)
    sets: list[tuple[float, float, float, np.ndarray]] = []  # (Sc_k, F_shift, mean C', lines)
    steps: list[dict] = []  # per processed frame without ids: step 4's inputs, step 3's tracks
    original = localiser_module.associate_landmarks
    original_track = localiser_module.track_lines

    def spy(u_lines, u_cands, scores, cfg, consistency=None):  # records the chosen set's terms
        best = original(u_lines, u_cands, scores, cfg, consistency)
        steps.append(dict(scores=scores, consistency=consistency, tracked=None))
        if min_score is not None and best.score < min_score:
            best = dataclasses.replace(best, lines=best.lines[:0], candidates=best.candidates[:0])
        if len(best):
            shift = np.asarray(u_lines)[best.lines] - np.asarray(u_cands)[best.candidates]
            c = scores[best.lines, best.candidates]
            sc, f = set_score(shift, np.asarray(u_lines)[best.lines], c, cfg)
            sets.append((sc, f, float(c.mean()), best.lines))
        else:
            sets.append((-np.inf, 0.0, np.nan, best.lines))
        return best

    def spy_track(*args, **kwargs):
        tracked = original_track(*args, **kwargs)
        steps[-1]["tracked"] = tracked
        return tracked

    localiser_module.associate_landmarks = spy
    localiser_module.track_lines = spy_track
    try:
        ukf = VerticalLineUKF(setup.prior, config, Modality.VERTICAL_LINES, setup.line)
        processed_s, processed_cpu_s, processed_index = [], [], []
        for frame in setup.log.frames:
            start, start_cpu = time.perf_counter(), time.process_time()
            ukf.step(frame)
            elapsed, cpu = time.perf_counter() - start, time.process_time() - start_cpu
            if ukf.associations and ukf.associations[-1].index == frame.index:
                processed_s.append(elapsed)
                processed_cpu_s.append(cpu)
                processed_index.append(frame.index)
    finally:
        localiser_module.associate_landmarks = original
        localiser_module.track_lines = original_track
    estimate = ukf.estimate()
    poses = estimate.trajectory.se2
    err = np.hypot(*(poses[:, :2] - setup.truth[:, :2]).T)
    d = poses - setup.truth
    d[:, 2] = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
    nees = np.einsum("ki,kij,kj->k", d, np.linalg.inv(estimate.pose_covariances), d)
    row = dict(
        mean_cm=err.mean() * 100,
        max_cm=err.max() * 100,
        nees=float(nees.mean()),
        frames=len(ukf.associations),
        ms=float(np.median(processed_s)) * 1e3 if processed_s else float("nan"),
        cpu_ms=float(np.median(processed_cpu_s)) * 1e3 if processed_cpu_s else float("nan"),
        pairs=0,
        wrong_pairs=0,
        used=0,
        wrong_used=0,
        seen=0,
        visible=0,
        updated=ukf.info().frames_updated,
        gated=ukf.info().pairs_gated_out,
        ukf=ukf,
        err=err,
        step_cpu_s=np.array(processed_cpu_s),
        processed_index=np.array(processed_index, dtype=np.int64),
        steps=steps,
        labels=[],
    )
    scored = []
    for k, a in enumerate(ukf.associations):
        labels = label_lines(setup.truth[a.index], a.bearings_rad, setup.prior, setup.line, 4.0)
        row["labels"].append(labels)
        row["seen"] += int((labels >= 0).sum())
        row["visible"] += len(a.candidates)
        row["pairs"] += len(a.pairs)
        wrong = sum(int(labels[i] != j) for i, j in a.pairs)
        row["wrong_pairs"] += wrong
        row["used"] += len(a.used)
        row["wrong_used"] += sum(int(labels[i] != j) for i, j in a.used)
        if spy_sets and k < len(sets) and len(a.pairs):
            sc, f, c, _ = sets[k]
            scored.append((sc, f, c, len(a.pairs), wrong))
    row["sets"] = scored
    return row


def _print_single(setup: Setup, options: dict[str, str], r: dict) -> None:
    err, err_dr, k = r["err"], setup.err_dr, max(r["frames"], 1)
    print(f"data: {setup.folder}; options {options}")
    print(
        f"UKF mean position error {err.mean() * 100:.1f} cm (max {err.max() * 100:.1f});"
        f" dead reckoning {err_dr.mean() * 100:.1f} cm (max {err_dr.max() * 100:.1f});"
        f" ratio {err_dr.mean() / err.mean():.1f}x"
    )
    extraction_ms = _extraction_cpu_ms(setup)
    print(
        f"processed frames {r['frames']}; steps 3-5 + update median {r['cpu_ms']:.2f} ms CPU"
        f" ({r['ms']:.2f} ms wall); steps 1-2 (the front end's vertical lines and PMCs) median"
        f" {extraction_ms:.2f} ms CPU per image; steps 1-5 {extraction_ms + r['cpu_ms']:.2f} ms"
        f" CPU per processed frame"
    )
    print(
        f"per processed frame: candidates {r['visible'] / k:.1f}, lines labelled"
        f" {r['seen'] / k:.1f}, step-4 pairs {r['pairs'] / k:.1f} ({r['wrong_pairs']} of"
        f" {r['pairs']} wrong), used {r['used'] / k:.2f} ({r['wrong_used']} of {r['used']}"
        f" wrong = {r['wrong_used'] / max(r['used'], 1):.1%})"
    )
    print(f"pose NEES mean {r['nees']:.2f} (3 when consistent)")
    offset_px, passed = _map_quality(setup)
    print(
        f"the map against the extracted lines (true poses, lines labelled within 4 px):"
        f" median |u_line - u_landmark| {offset_px:.2f} px; {passed:.0%} of the labelled lines"
        f" pass the photometric gate (sec. 3.2) against their landmark's surveyed MC"
    )
    print(r["ukf"].info())


def _map_quality(setup: Setup) -> tuple[float, float]:
    """Median image distance of labelled lines from their landmark's true projection [px], and
    the fraction of them whose MC passes the photometric gate against the map's MC."""
    from omnislam.core.measurement import Bearing2D
    from omnislam.ukf.config import PhotometricConfig
    from omnislam.ukf.photometric import colour_differences, mc_from_pmc, photometric_scores
    from omnislam.ukf.survey import label_lines

    prior = setup.prior
    row = {int(i): k for k, i in enumerate(prior.landmark_ids)}
    offsets, passed = [], []
    for frame in setup.log.frames:
        lines = frame.vertical_lines
        if lines is None or not len(lines):
            continue
        wTr = setup.truth[frame.index]
        labels = label_lines(wTr, lines.bearings_rad, prior, setup.line, 4.0)
        left, right = mc_from_pmc(lines.profiles)
        for i in np.flatnonzero(labels >= 0):
            j = row[int(labels[i])]
            b = Bearing2D().predict(wTr, prior.points_w[j : j + 1, :2], jacobians=False)[0][0]
            offsets.append(abs(float(setup.line.u_px(lines.bearings_rad[i : i + 1])[0]
                                     - setup.line.u_px(b)[0])))
            band, mean = colour_differences(
                left[i : i + 1], right[i : i + 1],
                prior.means_left[j : j + 1], prior.means_right[j : j + 1],
            )
            passed.append(bool(np.isfinite(photometric_scores(band, mean, PhotometricConfig()))))
    return float(np.median(offsets)), float(np.mean(passed))


#: --ablation: the paper's step 4 alone, then each addition (ours) on top
ABLATION = (
    (
        "the paper's step 4 alone (no covariance gates, Sc_k alone)",
        {"association.gate_probability": "none", "association.largest_set_first": "false"},
    ),
    (
        "pre-gate and joint gate, Sc_k alone",
        {"association.largest_set_first": "false", "association.nearest_line": "false"},
    ),
    (
        "defaults without the nearest-line rule",
        {"association.nearest_line": "false"},
    ),
    ("defaults (gates, largest consistent set, then Sc_k, nearest line)", {}),
    (
        "defaults with core's odometry noise (4x smaller)",
        {
            "motion_noise.a_vv": "0.05",
            "motion_noise.a_vw": "0.01",
            "motion_noise.a_wv": "0.01",
            "motion_noise.a_ww": "0.05",
        },
    ),
)


def _print_seeds(out: Path, noise: float, seeds: list[int], options: dict[str, str]) -> None:
    """One row per seed, then the means over the seeds (the must-show numbers).

    "steps 1-5" is measured per processed frame: the CPU time of steps 1-2 on that frame's
    image (``extract_vertical_lines``, the front end's vertical lines and PMCs) plus the CPU
    time of the localiser's step on it (steps 3-5 and the update); the median is over the
    processed frames of every seed.
    """
    print(f"corridor21, odometry noise x{noise:g} of the preset's alphas; options {options}")
    print(
        "| seed | UKF mean err [cm] | max [cm] | DR mean err [cm] | DR / UKF | validated pairs"
        " used (wrong) | landmarks in view / seen as lines / used per processed frame"
        " | step-4 pairs (wrong) | steps 3-5 ms CPU | steps 1-5 ms CPU | pose NEES |"
    )
    print("|---" * 11 + "|")
    ukf_cm, dr_cm, used, wrong, steps15, per_frame = [], [], 0, 0, [], np.zeros(3)
    for seed in seeds:
        setup = prepare(out, noise, seed)
        r = run_once(setup, options)
        total = _steps_1_to_5_cpu_s(setup, r)
        dr = setup.err_dr.mean() * 100
        k = max(r["frames"], 1)
        ukf_cm.append(r["mean_cm"])
        dr_cm.append(dr)
        used, wrong = used + r["used"], wrong + r["wrong_used"]
        steps15.extend(total.tolist())
        per_frame += np.array([r["visible"], r["seen"], r["used"]]) / k / len(seeds)
        print(
            f"| {seed} | {r['mean_cm']:.2f} | {r['max_cm']:.1f} | {dr:.1f}"
            f" | {dr / r['mean_cm']:.1f}"
            f" | {r['used']} ({r['wrong_used']})"
            f" | {r['visible'] / k:.1f} / {r['seen'] / k:.1f} / {r['used'] / k:.1f}"
            f" | {r['pairs']} ({r['wrong_pairs']}) | {r['cpu_ms']:.2f}"
            f" | {np.median(total) * 1e3:.2f} | {r['nees']:.2f} |",
            flush=True,
        )
    u, d = float(np.mean(ukf_cm)), float(np.mean(dr_cm))
    print(
        f"over seeds {seeds}: UKF mean position error {u:.2f} cm (seeds' max"
        f" {max(ukf_cm):.2f}); dead reckoning {d:.1f} cm; DR / UKF {d / u:.1f}x; wrong validated"
        f" pairs {wrong} of {used} ({wrong / max(used, 1):.2%}); per processed frame"
        f" {per_frame[0]:.1f} landmarks in view, {per_frame[1]:.1f} seen as lines,"
        f" {per_frame[2]:.1f} used; steps 1-5 median {np.median(steps15) * 1e3:.2f} ms CPU"
        f" per processed frame ({len(steps15)} frames)"
    )


def _steps_1_to_5_cpu_s(setup: Setup, r: dict) -> np.ndarray:
    """CPU time of steps 1-5 of each processed frame [s]: the extraction on its image plus the
    localiser's step (``run_once``'s ``step_cpu_s``)."""
    from omnislam.frontend.config import VerticalEdgeConfig
    from omnislam.frontend.vertical_edges import extract_vertical_lines

    config = VerticalEdgeConfig()
    extraction = []
    for index in r["processed_index"].tolist():
        image = setup.seq.image(int(index))
        start = time.process_time()
        extract_vertical_lines(image, setup.seq.calibration, config)
        extraction.append(time.process_time() - start)
    return np.asarray(extraction) + r["step_cpu_s"]


def _print_wrong(setup: Setup, r: dict) -> None:
    """Every wrong validated pair of a run, and what let it through.

    Per pair: the frame, the line, its true landmark (-1: an unmapped line) and the chosen one;
    the pair's innovation and predicted sigma (line and pose) [px at the image centre], its
    squared distance given the set's other pairs (the joint gate's 1-dof test, 10.8 at 0.999);
    the pose's error and sigmas; the landmark's own line (labelled by the truth), its distance
    and photometric differences against the landmark's MC (the gate: diff_banda <= 30,
    diff_media <= 100); how many consecutive processed frames step 4 paired the same tracked
    line with the same landmark. Then, over every validated pair, what two other rules would
    have kept, offline: validation over three frames, and the nearest line given the others
    (``association.nearest_line``).
    """
    from omnislam.core.se import wrap_angle
    from omnislam.ukf.photometric import colour_differences, mc_from_pmc

    px = setup.line.px_per_rad
    row_of = {int(i): k for k, i in enumerate(setup.prior.landmark_ids)}
    assocs, steps, labels = r["ukf"].associations, r["steps"], r["labels"]
    if len(steps) != len(assocs):
        print("(frames associated by id: nothing to dump)")
        return
    kept = {"three frames": [0, 0, 0, 0], "nearest line": [0, 0, 0, 0]}  # right/of, wrong/of

    def run_length(k: int, line: int, landmark: int) -> int:
        n = 1
        while k > 0 and steps[k]["tracked"] is not None and steps[k]["tracked"][line] >= 0:
            line = int(steps[k]["tracked"][line])
            if {int(i): int(j) for i, j in assocs[k - 1].pairs}.get(line) != landmark:
                break
            n, k = n + 1, k - 1
        return n

    print(
        "| frame | line | true | chosen | innovation [px] | sigma [px] | d2 given others |"
        " pose err x, y [cm], th [deg] (sigma) | own line: d2, diff_banda, diff_media |"
        " frames paired |"
    )
    print("|---" * 10 + "|")
    for k, a in enumerate(assocs):
        c = steps[k]["consistency"]
        if c is None or not len(a.pairs):
            continue
        lines = a.pairs[:, 0]
        cols = np.array([int(np.flatnonzero(a.candidates == j)[0]) for j in a.pairs[:, 1]])
        y = c.innovations_rad[lines, cols]
        S_inv = np.linalg.inv(c.prediction.covariance(cols) + np.diag(c.line_variance[lines]))
        given = (S_inv @ y) ** 2 / np.diag(S_inv)
        nearest = c.nearest_lines(lines, cols)
        used = {int(i) for i, _ in a.used}
        for n, (line, landmark) in enumerate(a.pairs.tolist()):
            if line not in used:
                continue
            right = int(labels[k][line] == landmark)
            for rule, keep in (
                ("three frames", run_length(k, line, landmark) >= 3),
                ("nearest line", bool(nearest[n])),
            ):
                kept[rule][2 * (1 - right)] += int(keep)
                kept[rule][2 * (1 - right) + 1] += 1
            if right:
                continue
            err = a.prior_pose - setup.truth[a.index]
            sd = np.sqrt(np.diag(a.prior_cov))
            sigma = math.sqrt(c.line_variance[line] + c.prediction.variance[cols[n]])
            own = np.flatnonzero(labels[k] == landmark)
            own_text = "not extracted"
            if own.size:
                o = int(own[0])
                profiles = setup.log.frames[a.index].vertical_lines.profiles
                left, right_mc = mc_from_pmc(profiles[o : o + 1])
                m = row_of[landmark]
                band, mean = colour_differences(
                    left,
                    right_mc,
                    setup.prior.means_left[m : m + 1],
                    setup.prior.means_right[m : m + 1],
                )
                d2 = c.pair_distances()[o, cols[n]]
                own_text = f"{d2:.2f}, {band[0, 0]:.0f}, {mean[0, 0]:.0f}"
            print(
                f"| {a.index} | {line} | {labels[k][line]} | {landmark} | {y[n] * px:+.1f}"
                f" | {sigma * px:.1f} | {given[n]:.2f} | {err[0] * 100:+.1f}, {err[1] * 100:+.1f},"
                f" {math.degrees(float(wrap_angle(err[2]))):+.2f} ({sd[0] * 100:.1f},"
                f" {sd[1] * 100:.1f}, {math.degrees(sd[2]):.2f}) | {own_text}"
                f" | {run_length(k, line, landmark)} |"
            )
    for rule, (r_kept, r_all, w_kept, w_all) in kept.items():
        print(
            f"offline, {rule}: keeps {r_kept} of {r_all} right validated pairs and {w_kept} of"
            f" {w_all} wrong"
        )


def _print_ablation(setup: Setup, options: dict[str, str]) -> None:
    print(
        f"data: {setup.folder}; dead reckoning mean {setup.err_dr.mean() * 100:.1f} cm;"
        f" options {options}"
    )
    print(_HEADER.format(key="step 4"))
    print("|---" * 10 + "|")
    for label, changes in ABLATION:
        print(_row(label, run_once(setup, {**options, **changes})), flush=True)


def _extraction_cpu_ms(setup: Setup, images: int = 30) -> float:
    """Median CPU time of steps 1-2 (``extract_vertical_lines``) over the first images [ms]."""
    from omnislam.frontend.config import VerticalEdgeConfig
    from omnislam.frontend.vertical_edges import extract_vertical_lines

    config = VerticalEdgeConfig()
    times = []
    for index in setup.seq.image_frames[:images]:
        image = setup.seq.image(int(index))
        start = time.process_time()
        extract_vertical_lines(image, setup.seq.calibration, config)
        times.append(time.process_time() - start)
    return float(np.median(times)) * 1e3


_HEADER = (
    "| {key} | mean err [cm] | max err [cm] | processed frames | updated | ms CPU / processed frame"
    " | step-4 pairs (wrong) | validated pairs used | wrong validated | pose NEES |"
)


def _row(value: str, r: dict) -> str:
    return (
        f"| {value} | {r['mean_cm']:.1f} | {r['max_cm']:.1f} | {r['frames']} | {r['updated']}"
        f" | {r['cpu_ms']:.2f} | {r['pairs']} ({r['wrong_pairs']}) | {r['used']}"
        f" | {r['wrong_used']} ({r['wrong_used'] / max(r['used'], 1):.1%}) | {r['nees']:.2f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="/tmp/ukf_corridor21")
    parser.add_argument("--noise", type=float, default=1.0, help="x the preset's alphas")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--set", nargs="*", default=[])
    parser.add_argument("--seeds", nargs="*", type=int, default=None, help="one row per seed")
    parser.add_argument("--ablation", action="store_true", help="what each addition does")
    parser.add_argument(
        "--sweep",
        nargs="*",
        type=float,
        default=None,
        metavar="CM",
        help=f"d_it sweep [cm] (no values: {SWEEP_CM})",
    )
    parser.add_argument(
        "--sck",
        nargs="*",
        type=float,
        default=None,
        metavar="W",
        help=f"Sc_k calibration: F_shift weights (no values: {SCK_WEIGHTS})",
    )
    parser.add_argument(
        "--sck-min",
        nargs="*",
        type=float,
        default=None,
        metavar="T",
        help=f"Sc_k thresholds (no values: {SCK_THRESHOLDS})",
    )
    parser.add_argument(
        "--image-every",
        type=int,
        default=None,
        metavar="K",
        help="one image every K odometry steps (preset: 12, about 36 cm; the"
        " sweep below that spacing needs a smaller K, e.g. 3)",
    )
    parser.add_argument(
        "--dump-wrong",
        action="store_true",
        help="with --sweep: every wrong validated pair and what let it through",
    )
    args = parser.parse_args()
    options = set_options(parser, args.set)
    if args.seeds is not None:
        _print_seeds(Path(args.out), args.noise, args.seeds or [0, 1, 2, 3, 4], options)
        return
    setup = prepare(Path(args.out), args.noise, args.seed, args.image_every)
    if args.ablation:
        _print_ablation(setup, options)
        return
    if args.sweep is None and args.sck is None and args.sck_min is None:
        _print_single(setup, options, run_once(setup, options))
        return
    print(
        f"data: {setup.folder} (odometry noise x{args.noise:g}); options {options};"
        f" dead reckoning mean {setup.err_dr.mean() * 100:.1f} cm,"
        f" max {setup.err_dr.max() * 100:.1f} cm"
    )
    if args.sweep is not None:
        print("\nd_it sweep (paper sec. 5)")
        print(_HEADER.format(key="d_it [cm]"))
        print("|---" * 10 + "|")
        for cm in args.sweep or SWEEP_CM:
            r = run_once(setup, {**options, "spacing.d_it_m": str(cm / 100)})
            print(_row(f"{cm:g}", r), flush=True)
            if args.dump_wrong:
                _print_wrong(setup, r)
    if args.sck is not None:
        print(
            "\nSc_k calibration: weight of F_shift in Sc_k = mean(C'_ij) + w F_shift"
            " (paper w = 100)"
        )
        print(_HEADER.format(key="w"))
        print("|---" * 10 + "|")
        chosen = None
        for w in args.sck or SCK_WEIGHTS:
            r = run_once(setup, {**options, "association.shift_weight": str(w)}, spy_sets=True)
            print(_row(f"{w:g}", r), flush=True)
            if w == 100.0:
                chosen = r
        if chosen is not None:
            _print_sets(chosen["sets"])
    if args.sck_min is not None:
        print("\nSc_k calibration: sets of Sc_k below a threshold are dropped (w = 100)")
        print(_HEADER.format(key="min Sc_k"))
        print("|---" * 10 + "|")
        for t in args.sck_min or SCK_THRESHOLDS:
            print(_row(f"{t:g}", run_once(setup, options, min_score=t)), flush=True)


def _print_sets(sets: list[tuple[float, float, float, int, int]]) -> None:
    """Sc_k, F_shift and mean C'_ij of the chosen step-4 sets: right vs holding a wrong pair."""
    a = np.array(sets, dtype=float).reshape(-1, 5)
    print("\nchosen step-4 sets at w = 100: all pairs right vs at least one wrong")
    print(
        "| sets | n | pairs / set | Sc_k median (p10-p90) | 100 F_shift median"
        " | mean C'_ij median |"
    )
    print("|---|---|---|---|---|---|")
    for label, mask in (("all right", a[:, 4] == 0), ("some wrong", a[:, 4] > 0)):
        s = a[mask]
        if not len(s):
            print(f"| {label} | 0 | | | | |")
            continue
        p10, p50, p90 = np.percentile(s[:, 0], [10, 50, 90])
        print(
            f"| {label} | {len(s)} | {s[:, 3].mean():.2f} | {p50:.1f} ({p10:.1f}-{p90:.1f})"
            f" | {np.median(s[:, 1]) * 100:.1f} | {np.nanmedian(s[:, 2]):.2f} |"
        )
    right, wrong = a[a[:, 4] == 0, 0], a[a[:, 4] > 0, 0]
    if len(right) and len(wrong):
        best = max(
            ((float(np.sum(right >= t) - np.sum(wrong >= t)), t) for t in np.unique(a[:, 0])),
        )
        t = best[1]
        print(
            f"a threshold Sc_k >= {t:.1f} keeps {np.sum(right >= t)} of {len(right)} right sets"
            f" and {np.sum(wrong >= t)} of {len(wrong)} with a wrong pair"
        )


if __name__ == "__main__":
    main()
