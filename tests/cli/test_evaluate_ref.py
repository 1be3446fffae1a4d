"""``omnislam evaluate --ref GT EST``: trajectories from outside, against evo as the oracle.

evo's own command-line tools (``evo_ape``, ``evo_rpe``) run on the very files omnislam reads,
for every alignment, and must give the same statistics.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from omnislam.cli import main
from omnislam.core.se import se3_exp
from omnislam.core.types import Trajectory
from omnislam.datasets.trajectory_io import detect_trajectory_format, write_kitti, write_tum
from omnislam.errors import DataError

#: ours against evo's, on the same files (both read 17 significant digits) [m] and [deg]
EVO_TOL = 1e-9
#: RPE segment of the comparison [m]; evo_rpe --delta M --delta_unit m --delta_tol 0.1
SEGMENT_M = 4.0

#: alignment -> evo's flags (SE(2) is evo's -a on a planar run: the same optimum in the plane)
EVO_FLAGS = {
    "none": [],
    "origin": ["--align_origin"],
    "se2": ["-a"],
    "se3": ["-a"],
    "sim3": ["-a", "-s"],
}


def planar_pair(n: int = 300, seed: int = 3) -> tuple[Trajectory, Trajectory]:
    """A planar ground truth (45 m of travel) and a drifting, scaled, offset estimate of it,
    at a subset of the stamps with a few milliseconds of jitter."""
    rng = np.random.default_rng(seed)
    yaw = np.cumsum(rng.normal(0.03, 0.06, n))
    xy = np.cumsum(0.15 * np.column_stack([np.cos(yaw), np.sin(yaw)]), axis=0)
    stamps = 0.1 * np.arange(n)
    truth = Trajectory.from_se2(stamps, np.column_stack([xy, yaw]))
    drift = np.cumsum(rng.normal(0, 0.004, n))
    c, s = np.cos(0.4), np.sin(0.4)
    est_xy = 1.04 * (xy @ np.array([[c, -s], [s, c]]).T) + [3.0, -1.0]
    est_xy += rng.normal(0, 0.03, (n, 2)) + np.column_stack([drift, -drift])
    keep = np.sort(rng.choice(n, size=n - 20, replace=False))
    est = np.column_stack([est_xy, yaw + 0.4 + rng.normal(0, 0.01, n)])[keep]
    jitter = rng.uniform(-0.003, 0.003, len(keep))
    return truth, Trajectory.from_se2(stamps[keep] + jitter, est)


def spatial_pair(n: int = 200, seed: int = 5) -> tuple[Trajectory, Trajectory]:
    """A 3-D ground truth (roll, pitch and height vary) and a noisy estimate of it."""
    rng = np.random.default_rng(seed)
    twists = np.column_stack([rng.normal(0.2, 0.02, n), rng.normal(0, 0.03, (n, 5))])
    poses = np.cumsum(twists, axis=0)
    truth = se3_exp(poses)
    est = truth @ se3_exp(rng.normal(0, 0.03, size=(n, 6)))
    stamps = np.arange(n, dtype=float)
    offset = se3_exp(np.array([1.0, -2.0, 0.5, 0.1, -0.2, 0.3]))
    est = offset @ est
    est[:, :3, 3] *= 0.95
    return Trajectory(stamps, truth), Trajectory(stamps, est)


def _evo(tool: str, fmt: str, gt: Path, est: Path, flags: list[str], out: Path) -> dict:
    """Run an evo command-line tool and return the stats it saved."""
    command = shutil.which(tool) or str(Path(sys.executable).with_name(tool))
    done = subprocess.run(
        [command, fmt, str(gt), str(est), *flags, "--save_results", str(out), "--no_warnings"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, f"{tool} {' '.join(flags)} failed:\n{done.stdout}{done.stderr}"
    with zipfile.ZipFile(out) as archive:
        return json.loads(archive.read("stats.json"))


def _ours(capsys, gt: Path, est: Path, alignment: str) -> dict:
    argv = ["evaluate", str(est), "--ref", str(gt), "--align", alignment, "--json"]
    assert main([*argv, "--rpe-segment", str(SEGMENT_M)]) == 0
    return json.loads(capsys.readouterr().out)


def _assert_stats(ours: dict, evo: dict, what: str) -> None:
    for key in ("rmse", "mean", "median", "std", "min", "max"):
        assert abs(ours[key] - evo[key]) < EVO_TOL, (what, key, ours[key], evo[key])


@pytest.mark.slow
@pytest.mark.parametrize(
    ("kind", "alignments", "checks"),
    [
        # every alignment: ATE, RPE translation and rotation over SEGMENT_M; RPE of 1 frame
        ("planar-tum", ("none", "origin", "se2", "se3", "sim3"), ("ate", "rpe_trans", "rpe_rot")),
        ("spatial-tum", ("none", "origin", "se3", "sim3"), ("ate", "rpe_trans")),
        ("planar-kitti", ("sim3",), ("ate", "rpe_trans", "frame_trans")),
    ],
)
def test_agrees_with_evo_ape_and_evo_rpe_for_every_alignment(
    kind, alignments, checks, tmp_path, capsys
):
    pytest.importorskip("evo")
    shape, fmt = kind.split("-")
    truth, estimate = planar_pair() if shape == "planar" else spatial_pair()
    if fmt == "kitti":  # no stamps in KITTI: one pose per line on both sides
        truth, estimate = planar_pair()[0], planar_pair()[0]
        rng = np.random.default_rng(7)
        noisy = truth.se2 + rng.normal(0, [0.05, 0.05, 0.01], truth.se2.shape)
        estimate = Trajectory.from_se2(truth.stamps_s, 1.1 * noisy * [1, 1, 1 / 1.1])
    gt, est = tmp_path / f"gt.{fmt}", tmp_path / f"est.{fmt}"
    writer = write_tum if fmt == "tum" else write_kitti
    writer(gt, truth)
    writer(est, estimate)
    assert detect_trajectory_format(gt) == detect_trajectory_format(est) == fmt

    rpe_flags = ["--delta", str(SEGMENT_M), "--delta_unit", "m", "--delta_tol", "0.1"]
    rpe_flags += ["--all_pairs", "--pairs_from_reference"]
    jobs = {}
    for alignment in alignments:  # evo's tools, all at once (each is mostly its start-up)
        flags = EVO_FLAGS[alignment]
        every = {
            "ate": ("evo_ape", [*flags, "-r", "trans_part"]),
            "rpe_trans": ("evo_rpe", [*flags, *rpe_flags, "-r", "trans_part"]),
            "rpe_rot": ("evo_rpe", [*flags, *rpe_flags, "-r", "angle_deg"]),
            "frame_trans": ("evo_rpe", [*flags, "--delta", "1", "-u", "f", "-r", "trans_part"]),
        }
        jobs[alignment] = [(name, *every[name]) for name in checks]
    from concurrent.futures import ThreadPoolExecutor

    ordered = [((a, name), tool, flags) for a, job in jobs.items() for name, tool, flags in job]
    # evo writes its settings (~/.evo) on its first run on a machine, and first runs started
    # together race for that file (seen on a fresh machine): the first job runs alone
    (key, tool, flags), rest = ordered[0], ordered[1:]
    evo = {key: _evo(tool, fmt, gt, est, flags, tmp_path / f"{key[0]}-{key[1]}.zip")}
    with ThreadPoolExecutor(max_workers=4) as pool:
        futures = {
            key: pool.submit(_evo, tool, fmt, gt, est, flags, tmp_path / f"{key[0]}-{key[1]}.zip")
            for key, tool, flags in rest
        }
        evo |= {key: future.result() for key, future in futures.items()}

    field = {
        "ate": "ate_m",
        "rpe_trans": "rpe_trans_m",
        "rpe_rot": "rpe_rot_deg",
        "frame_trans": "rpe_frame_trans_m",
    }
    for alignment in alignments:
        ours = _ours(capsys, gt, est, alignment)
        assert ours["alignment"] == alignment and ours["rpe_pairs"] > 10
        for name in checks:
            _assert_stats(ours[field[name]], evo[alignment, name], (kind, alignment, name))
    if "sim3" in alignments and "se3" in alignments:  # the scale is what Sim(3) adds
        assert evo["sim3", "ate"]["rmse"] < evo["se3", "ate"]["rmse"]


def test_prints_a_table_with_every_statistic(tmp_path, capsys):
    truth, estimate = planar_pair()
    write_tum(tmp_path / "gt.tum", truth)
    write_tum(tmp_path / "est.tum", estimate)
    assert main(["evaluate", str(tmp_path / "est.tum"), "--ref", str(tmp_path / "gt.tum")]) == 0
    out = capsys.readouterr().out
    assert "280 poses matched" in out and "aligned se2" in out
    for row in ("ATE [m]", "RPE 10 m trans [m]", "RPE 10 m rot [deg]", "RPE 1 frame trans"):
        assert row in out, out
    assert not list(tmp_path.glob("*.json"))  # nothing written without --out


def test_a_short_run_gets_a_segment_it_has_and_a_missing_value_says_why(tmp_path, capsys):
    truth, estimate = planar_pair(n=60)  # 9 m of travel: 10 m segments would find no pair
    write_tum(tmp_path / "gt.tum", truth)
    write_tum(tmp_path / "est.tum", estimate)
    argv = ["evaluate", str(tmp_path / "est.tum"), "--ref", str(tmp_path / "gt.tum"), "--json"]
    assert main(argv) == 0
    numbers = json.loads(capsys.readouterr().out)
    assert numbers["rpe_segment_m"] == 2.0 and numbers["rpe_pairs"] > 20  # 1-2-5 <= 9 m / 4
    assert main([*argv, "--rpe-segment", "50"]) == 0
    numbers = json.loads(capsys.readouterr().out)
    assert numbers["rpe_pairs"] == 0 and numbers["rpe_trans_m"]["rmse"] is None
    assert re.search(r"the reference travels 8\.\d m", numbers["missing"]["rpe"]), numbers
    assert main([*argv[:-1], "--rpe-segment", "50"]) == 0
    table = capsys.readouterr().out
    line = next(x for x in table.splitlines() if "RPE 50 m trans" in x)
    assert "no pose pair 50 m of reference travel apart" in line


def test_bad_reference_files_are_one_line_errors(tmp_path, capsys):
    truth, estimate = planar_pair(n=40)
    write_tum(tmp_path / "gt.tum", truth)
    write_kitti(tmp_path / "est.kitti", estimate)
    (tmp_path / "bad.txt").write_text("# a comment\n1 2 3\n")
    cases = [
        (["--ref", str(tmp_path / "gt.tum"), str(tmp_path / "est.kitti")], "est.kitti"),
        (["--ref", str(tmp_path / "bad.txt"), str(tmp_path / "est.kitti")], "bad.txt: line 2"),
        (["--ref", str(tmp_path / "none.tum"), str(tmp_path / "est.kitti")], "none.tum"),
        (["--ref", str(tmp_path / "gt.tum"), str(tmp_path / "gt.tum"), "--align", "x"], "--align"),
    ]
    for extra, needle in cases:
        try:
            result = main(["evaluate", *extra])
        except SystemExit as exc:  # a usage error: argparse's one line
            result = exc.code
        assert result == 2, extra
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and needle in err, err


def test_format_detection_names_the_line(tmp_path):
    (tmp_path / "x.txt").write_text("# header\n\n1 2 3 4 5\n")
    with pytest.raises(DataError, match=r"x.txt: line 3: 5 values"):
        detect_trajectory_format(tmp_path / "x.txt")


# ---- several estimates against one reference (evo_res's use) and --plot ------------------------


def estimates_of(truth: Trajectory, seeds: tuple[int, ...]) -> list[Trajectory]:
    """Estimates of one planar ground truth: each rotated, offset, scaled a little and drifting
    differently, at its own subset of the stamps with a few milliseconds of jitter."""
    out = []
    for seed in seeds:
        rng = np.random.default_rng(seed)
        n = len(truth.stamps_s)
        angle = rng.uniform(-1.0, 1.0)
        c, s = np.cos(angle), np.sin(angle)
        se2 = truth.se2.copy()
        drift = np.cumsum(rng.normal(0, 0.005, (n, 2)), axis=0)
        se2[:, :2] = rng.uniform(0.95, 1.05) * se2[:, :2] @ np.array([[c, -s], [s, c]]).T
        se2[:, :2] += rng.normal(0, 2.0, 2) + drift + rng.normal(0, 0.03, (n, 2))
        se2[:, 2] += angle + rng.normal(0, 0.01, n)
        keep = np.sort(rng.choice(n, size=n - 15, replace=False))
        stamps = truth.stamps_s[keep] + rng.uniform(-0.003, 0.003, len(keep))
        out.append(Trajectory.from_se2(stamps, se2[keep]))
    return out


def _evo_ape_stats(gt: Path, est: Path, alignment: str) -> dict:
    """evo_ape's statistics of ``est`` against ``gt`` through evo's Python API."""
    from evo.core import metrics, sync
    from evo.tools import file_interface

    reference = file_interface.read_tum_trajectory_file(str(gt))
    estimate = file_interface.read_tum_trajectory_file(str(est))
    reference, estimate = sync.associate_trajectories(reference, estimate)
    if alignment != "none":
        estimate.align(reference, correct_scale=alignment == "sim3")
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((reference, estimate))
    return ape.get_all_statistics()


@pytest.mark.parametrize("alignment", ["none", "se2", "sim3"])
def test_three_estimates_in_one_table_each_as_evo_ape(alignment, tmp_path, capsys):
    pytest.importorskip("evo")
    truth, _ = planar_pair()
    gt = tmp_path / "gt.tum"
    write_tum(gt, truth)
    paths = []
    for i, estimate in enumerate(estimates_of(truth, (21, 22, 23))):
        paths.append(tmp_path / f"est{i}.tum")
        write_tum(paths[-1], estimate)
    argv = ["evaluate", *map(str, paths), "--ref", str(gt), "--align", alignment]
    assert main([*argv, "--json"]) == 0
    numbers = json.loads(capsys.readouterr().out)
    assert numbers["alignment"] == alignment and numbers["reference"] == str(gt)
    assert [e["estimate"] for e in numbers["estimates"]] == list(map(str, paths))
    rmses = []
    for path, ours in zip(paths, numbers["estimates"], strict=True):
        _assert_stats(ours["ate_m"], _evo_ape_stats(gt, path, alignment), (path.name, alignment))
        rmses.append(ours["ate_m"]["rmse"])
    assert len(set(rmses)) == 3  # three different estimates, three different numbers

    assert main(argv) == 0  # the table: a header and one row per estimate, in the given order
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"3 estimates against {gt} (tum), aligned {alignment}")
    rows = [line.split() for line in lines[2:5]]
    assert [row[0] for row in rows] == list(map(str, paths))
    assert [float(row[3]) for row in rows] == pytest.approx(rmses, rel=1e-3)  # 4 digits shown


def _svg_texts(path: Path) -> list[str]:
    import xml.etree.ElementTree as ElementTree

    root = ElementTree.parse(path).getroot()
    return [t.text or "" for t in root.iter() if t.tag.endswith("text")] + [
        (t.text or "") for t in root.iter() if t.tag.endswith("title")
    ]


def test_plot_draws_every_estimate_and_the_error_over_time(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    truth, _ = planar_pair()
    gt = tmp_path / "gt.tum"
    write_tum(gt, truth)
    paths = []
    for i, estimate in enumerate(estimates_of(truth, (31, 32))):
        paths.append(tmp_path / f"est{i}.tum")
        write_tum(paths[-1], estimate)
    argv = ["evaluate", *map(str, paths), "--ref", str(gt)]
    for suffix, magic in ((".svg", b"<?xml"), (".pdf", b"%PDF"), (".png", b"\x89PNG")):
        plot = tmp_path / f"plot{suffix}"
        assert main([*argv, "--plot", str(plot)]) == 0
        assert f"-> {plot}" in capsys.readouterr().out
        assert plot.read_bytes().startswith(magic), suffix
    svg = " ".join(_svg_texts(tmp_path / "plot.svg"))
    for text in ("reference", str(paths[0]), str(paths[1]), "translation error [m]", "x [m]"):
        assert text in svg, text
    # the same files, twice: the same figure (no date in an SVG)
    again = tmp_path / "again.svg"
    assert main([*argv, "--plot", str(again)]) == 0
    assert again.read_bytes() == (tmp_path / "plot.svg").read_bytes()


def test_plot_of_a_run_dir_is_its_estimate_against_its_ground_truth(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from room_log import write_room_log

    log = write_room_log(tmp_path / "room.log", frames=30)
    run = tmp_path / "run"
    assert main(["run", str(log), "--estimator", "deadreckoning", "--out", str(run)]) == 0
    plot = tmp_path / "run.svg"
    assert main(["evaluate", str(run), "--plot", str(plot)]) == 0
    assert f"and {plot}" in capsys.readouterr().out
    svg = " ".join(_svg_texts(plot))
    assert "deadreckoning" in svg and "reference" in svg and "aligned se2" in svg
    assert (run / "metrics.json").is_file()
