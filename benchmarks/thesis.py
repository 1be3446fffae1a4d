"""The thesis's two simulated experiments (Guizilini 2008, sec. 5.1.2, Figs. 5.4-5.8) as one grid.

On ``thesis-route1`` and ``thesis-route2`` (laser and poles, no ids, zero-mean odometry noise;
``omnislam.datasets.synthetic.presets``), every seed a different world and noise draw: FastSLAM
1.0 with 10/50/200/1000 particles and 2.0 with 10/50/200, both with the existence index of sec.
5.1.2 over the pole laser's 4 m range (``existence.max_range_m=4``), association by position
(the presets hide the ids), everything else the estimators' defaults; graphslam, EKF-SLAM and
dead reckoning on the same runs. The runs are a harness grid (``omnislam.harness``: the same
cells ``omnislam compare`` runs, resumed when the folder holds them already), so every number
is the one ``omnislam run`` + ``omnislam evaluate`` give. For each run (``thesis_metrics``): ATE
(SE(2) aligned), the end pose's error (start anchored), the map's landmark error, poles mapped
twice and landmarks per sighted pole, whether and where the loop closes (the first revisit of a
pole seen long before that re-associates it) and the share of revisits that re-associate,
before and after the longest blind stretch (route 2's corridor without poles)::

    python benchmarks/thesis.py --out runs/thesis [--routes 1 2] [--seeds 0 1 2 3 4]
        [--configs fs1-50 fs2-10 graphslam] [--noise-scale 1 0.5 0.25] [--workers 1]
        [--figure-seed 0 | --no-figures]

The thesis states no odometry coefficients, so ``--noise-scale S`` runs the presets with their
alpha coefficients (``THESIS_MOTION_NOISE``) multiplied by S: the simulated robot's odometry,
not any estimator's setting (every estimator keeps its defaults). The same seed draws the same
world, sightings and odometry noise at every scale, only scaled. Scale 1 is the registered
preset: a grid over ``{synthetic: thesis-routeR}``, rendered into the harness's cache, in
``OUT/runs/``. Any other scale is rendered per seed into a folder of its own,
``OUT/renders/thesis-routeR-xS-sSEED-BACKEND-KEY`` (the registered render's folder name with the
scale inserted: KEY covers the preset, seed, backend and renderer code), and run by a grid over
those folders with that seed, ``OUT/runs-xS/sSEED/`` (one results folder per seed, since a grid
gives every folder on disk the same seeds); ``omnislam run FOLDER --seed SEED`` gives the same
run.

Writes the results folders, ``OUT/thesis.csv`` (one row per run), ``OUT/thesis.md`` (per route,
scale and configuration: median [min-max] over the seeds) and ``OUT/figures/routeR-sS.png``
(``routeR-xS-sS.png`` at other scales; the maps drawn as the thesis's Figs. 5.6 and 5.8: the
occupancy grid of the 180 deg laser on each estimated trajectory, with its landmarks and the
true poles).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path

import numpy as np
import thesis_metrics as tm
import yaml

from omnislam.datasets.registry import load_dataset, resolve
from omnislam.datasets.synthetic.loader import is_synthetic_folder
from omnislam.datasets.synthetic.presets import PRESETS, Preset
from omnislam.datasets.synthetic.simulate import simulate
from omnislam.datasets.synthetic.writer import write_synthetic
from omnislam.harness.grid import Cell, Grid, parse_grid
from omnislam.harness.layout import CELLS
from omnislam.harness.renders import RenderSpec, render_spec
from omnislam.harness.rundir import RunRecord, read_run_dir
from omnislam.harness.runner import CellOutcome, local_executor_factory, run_grid
from omnislam.metrics.trajectory import Alignment, ate

ROUTES = {1: "thesis-route1", 2: "thesis-route2"}
#: the pole laser's range: the existence index's sensor field (thesis sec. 5.1.1)
POLE_LASER_RANGE_M = 4.0


@dataclass(frozen=True, slots=True)
class Config:
    """One column of the experiment: an estimator, and its particles for FastSLAM."""

    label: str
    estimator: str
    particles: int | None = None
    options: tuple[tuple[str, object], ...] = ()

    def entry(self) -> dict[str, object]:
        """The grid's estimator entry."""
        if self.particles is None:
            return {"estimator": self.estimator, "label": self.label}
        options = {"particles.n_particles": self.particles,
                   "existence.max_range_m": POLE_LASER_RANGE_M, **dict(self.options)}
        return {"estimator": self.estimator, "label": self.label, "options": options}

    def with_options(self, options: dict[str, object]) -> Config:
        """FastSLAM's configuration with more options, under a label of its own (``+set``)
        so its cells never mix with the defaults' in a results folder; others as they are."""
        if self.particles is None or not options:
            return self
        return Config(f"{self.label}+set", self.estimator, self.particles,
                      tuple(sorted(options.items())))


CONFIGS = (
    *(Config(f"fs1-{p}", "fastslam1", p) for p in (10, 50, 200, 1000)),
    *(Config(f"fs2-{p}", "fastslam2", p) for p in (10, 50, 200)),
    Config("graphslam", "graphslam"),
    Config("ekfslam", "ekfslam"),
    Config("deadreckoning", "deadreckoning"),
)


@dataclass(frozen=True, slots=True)
class Row:
    """One run's figures (a line of ``thesis.csv``)."""

    route: int
    noise_scale: float
    config: str
    seed: int
    ate_m: float
    end_error_m: float
    landmark_rmse_m: float
    landmarks: int
    poles_sighted: int
    landmarks_per_pole: float
    poles_mapped_twice: int
    landmarks_far: int
    revisits: int
    first_chance_m: float
    chance_error_m: float
    chance_spread_m: float
    closed_m: float
    closed_frame: int
    revisits_reassociated: float
    blind_end_m: float
    after_blind_reassociated: float
    cpu_s: float

    @property
    def chance_sigmas(self) -> float:
        """The error at the first revisit in the estimate's own stds there (NaN: none stated)."""
        if not self.chance_spread_m > 0:
            return math.nan
        return self.chance_error_m / self.chance_spread_m


@dataclass(frozen=True, slots=True)
class RouteTruth:
    """What a render's truth says, shared by every run on it."""

    sightings: tm.Sightings
    travel_m: np.ndarray
    found: list[tm.Revisit]
    blind_end_m: float


@dataclass(frozen=True, slots=True)
class Experiment:
    """One grid of the experiment and where its results go.

    Attributes:
        scale: the odometry noise's scale (1: the registered presets).
        grid: the harness grid.
        results_dir: its results folder.
    """

    scale: float
    grid: Grid
    results_dir: Path


def main() -> None:
    args = _arguments()
    out = Path(args.out).resolve()
    configs = [c.with_options(args.fastslam_set) for c in CONFIGS
               if not args.configs or c.label in args.configs]
    rows, done = [], []
    for scale in args.noise_scale:
        for experiment in experiments(out, args.routes, args.seeds, configs, scale):
            result = run_grid(experiment.grid, experiment.results_dir,
                              local_executor_factory(args.workers), on_outcome=_say)
            rows += _measure(result.outcomes, experiment.results_dir / CELLS, scale)
            done.append(experiment)
    _write_csv(out / "thesis.csv", rows)
    table = markdown(rows, configs, args.seeds)
    (out / "thesis.md").write_text(table)
    print(table)
    if not args.no_figures:
        for experiment in done:
            _draw(out, args.routes, args.figure_seed, configs, experiment)


def _arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="runs/thesis", help="output folder (default %(default)s)")
    parser.add_argument("--routes", type=int, nargs="+", choices=sorted(ROUTES), default=[1, 2])
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(10)))
    parser.add_argument("--configs", nargs="+", choices=[c.label for c in CONFIGS],
                        help="run only these configurations (default: all)")
    parser.add_argument("--noise-scale", type=float, nargs="+", default=[1.0],
                        help="the presets' odometry alphas times these (default 1)")
    parser.add_argument("--fastslam-set", nargs="+", default=[], metavar="KEY=VALUE",
                        help="more FastSLAM options (a diagnostic: its columns are then "
                        "labelled +set)")
    parser.add_argument("--workers", type=int, default=1, help="grid workers (0: in process)")
    parser.add_argument("--figure-seed", type=int, default=0, help="the seed the maps show")
    parser.add_argument("--no-figures", action="store_true")
    args = parser.parse_args()
    if not args.no_figures and args.figure_seed not in args.seeds:
        parser.error(f"--figure-seed {args.figure_seed} is not among --seeds")
    if any(s <= 0 for s in args.noise_scale):
        parser.error("--noise-scale takes positive numbers")
    pairs = [kv.partition("=") for kv in args.fastslam_set]
    if any(not key or not sep for key, sep, _ in pairs):
        parser.error("--fastslam-set takes KEY=VALUE")
    args.fastslam_set = {key: yaml.safe_load(value) for key, _, value in pairs}
    return args


# -- the odometry noise's scale -------------------------------------------------------------
def scale_text(scale: float) -> str:
    """The scale as folder names and tables write it: ``x0.5``."""
    return f"x{scale:g}"


def scaled_preset(name: str, scale: float) -> Preset:
    """The registered preset ``name`` with its odometry's alpha coefficients (thesis eq. 4.40)
    times ``scale``, named ``NAME-xS``; scale 1 is the registered preset itself.

    Only the alphas scale: the stds' floor and the reference step stay the preset's."""
    preset = PRESETS[name]
    if scale == 1:
        return preset
    noise = preset.motion_noise
    scaled = replace(noise, a_vv=noise.a_vv * scale, a_vw=noise.a_vw * scale,
                     a_wv=noise.a_wv * scale, a_ww=noise.a_ww * scale)
    return replace(preset, name=f"{name}-{scale_text(scale)}", motion_noise=scaled,
                   description=f"{preset.description}; odometry alphas {scale_text(scale)}")


def scaled_render(name: str, scale: float, seed: int) -> RenderSpec:
    """The render of ``scaled_preset(name, scale)`` for ``seed``: the registered render's spec
    (its key covers the preset, the seed, the backend and the renderer's code) with the scaled
    preset's name, so its folder is the registered one's with the scale inserted; scale 1 is
    the registered render."""
    return replace(render_spec(name, seed), preset=scaled_preset(name, scale).name)


def ensure_scaled_render(name: str, scale: float, seed: int, renders_dir: Path) -> Path:
    """The folder of ``scaled_render`` under ``renders_dir``, rendered unless it is there (the
    writer renames a finished folder into place, so a folder that is there is complete)."""
    spec = scaled_render(name, scale, seed)
    path = spec.path(renders_dir)
    if not is_synthetic_folder(path):
        print(f"  rendering {path.name}", file=sys.stderr, flush=True)
        sim = simulate(scaled_preset(name, scale), seed, backend=spec.backend)
        write_synthetic(path, sim, backend=spec.backend, overwrite=True)
    return path


def experiments(
    out: Path, routes: Sequence[int], seeds: list[int], configs: Sequence[Config], scale: float
) -> list[Experiment]:
    """The grids of one scale: at 1, one over the registered presets in ``OUT/runs``; else one
    per seed over that seed's scaled renders (rendered first), in ``OUT/runs-xS/sSEED``."""
    if scale == 1:
        datasets = [{"synthetic": ROUTES[r], "label": f"route{r}"} for r in routes]
        text = grid_text("thesis", datasets, seeds, configs)
        return [Experiment(scale, parse_grid(text, out / "thesis.yaml"), out / "runs")]
    found = []
    for seed in seeds:
        datasets = [
            {"dataset": str(ensure_scaled_render(ROUTES[r], scale, seed, out / "renders")),
             "label": f"route{r}"}
            for r in routes
        ]
        name = f"thesis-{scale_text(scale)}-s{seed}"
        grid = parse_grid(grid_text(name, datasets, [seed], configs), out / f"{name}.yaml")
        found.append(Experiment(scale, grid, out / f"runs-{scale_text(scale)}" / f"s{seed}"))
    return found


def grid_text(
    name: str, datasets: list[dict[str, str]], seeds: list[int], configs: Sequence[Config]
) -> str:
    """The experiment as a harness grid (YAML)."""
    grid = {
        "name": name,
        "datasets": datasets,
        "estimators": [c.entry() for c in configs],
        "seeds": seeds,
    }
    return yaml.safe_dump(grid, sort_keys=False)


def _draw(
    out: Path, routes: Iterable[int], seed: int, configs: Sequence[Config], experiment: Experiment
) -> None:
    """The maps of ``seed`` on every route, if the experiment ran that seed."""
    cells = [c for c in experiment.grid.cells if c.spec.seed == seed]
    if not cells:
        return
    noise = "" if experiment.scale == 1 else f"-{scale_text(experiment.scale)}"
    for route in routes:
        path = out / "figures" / f"route{route}{noise}-s{seed}.png"
        draw_maps(path, route, seed, configs, experiment.results_dir / CELLS, cells,
                  experiment.scale)
        print(f"figure: {path}")


def _say(outcome: CellOutcome) -> None:
    cost = "" if outcome.time is None else f" ({outcome.time.cpu_s:.0f} s CPU)"
    why = f": {outcome.error}" if outcome.error else ""
    print(f"  {outcome.cell.cell_id}: {outcome.status.value}{cost}{why}", file=sys.stderr,
          flush=True)


# -- the measurements of one run ---------------------------------------------------------
def _measure(outcomes: Iterable[CellOutcome], cells_dir: Path, scale: float) -> list[Row]:
    """One Row per finished cell, the render's truth read once per (route, seed); ``scale``:
    the odometry noise's scale of the renders."""
    truths: dict[str, RouteTruth] = {}
    rows = []
    for outcome in outcomes:
        if outcome.metrics is None:
            continue
        record = read_run_dir(cells_dir / outcome.cell.cell_id)
        path = record.config.dataset_path
        if path not in truths:
            truths[path] = route_truth(path, record)
        rows.append(measure_run(outcome, record, truths[path], scale))
    return rows


def route_truth(dataset_path: str, record: RunRecord) -> RouteTruth:
    """The sightings with their true ids, the travel, the revisits and the blind stretch."""
    sequence = load_dataset(resolve(dataset_path), {"association": "known"})
    frames, poles, ranges, bearings = [], [], [], []
    for k, rb in enumerate(sequence.range_bearing or ()):
        if rb is None or not len(rb):
            continue
        frames.append(np.full(len(rb), k))
        poles.append(rb.landmark_ids)
        ranges.append(rb.ranges_m)
        bearings.append(rb.bearings_rad)
    sightings = tm.Sightings(*(np.concatenate(a) for a in (frames, poles, ranges, bearings)))
    truth = record.ground_truth.trajectory
    travel = tm.travelled_m(truth.positions_w[:, :2])
    _, blind_end = tm.blind_stretch(sightings, travel)
    return RouteTruth(sightings, travel, tm.revisits(sightings, travel), blind_end)


def measure_run(
    outcome: CellOutcome, record: RunRecord, truth: RouteTruth, scale: float = 1.0
) -> Row:
    """The thesis's figures of one run (``thesis_metrics``) beside the harness's metrics;
    ``scale``: the odometry noise's scale of its render."""
    metrics, estimate, gt = outcome.metrics, record.estimate, record.ground_truth
    assert metrics is not None and gt.trajectory is not None
    wTr = estimate.trajectory.se2
    anchored = ate(estimate.trajectory, gt.trajectory, Alignment.ORIGIN).gtTest
    aligned = ate(estimate.trajectory, gt.trajectory, Alignment.SE2).gtTest
    sighted = np.isin(gt.landmark_ids, truth.sightings.poles)
    map_w = estimate.landmarks_w[:, :2] @ aligned[:2, :2].T + aligned[:2, 3]
    duplicates = tm.pole_duplicates(map_w, gt.landmarks_w[sighted, :2])
    errors = tm.revisit_errors(truth.sightings, truth.found, wTr)
    closure = tm.loop_closure(truth.found, errors, truth.blind_end_m)
    cell = outcome.cell
    return Row(
        route=int(cell.dataset_label.removeprefix("route")),
        noise_scale=scale,
        config=cell.estimator_label,
        seed=int(cell.spec.seed),
        ate_m=_number(metrics.ate.rmse_m),
        end_error_m=_pose_error(wTr, anchored, gt.trajectory.se2, len(wTr) - 1),
        landmark_rmse_m=_number(metrics.landmarks.rmse_m),
        landmarks=len(estimate.landmark_ids),
        poles_sighted=int(sighted.sum()),
        landmarks_per_pole=len(estimate.landmark_ids) / max(int(sighted.sum()), 1),
        poles_mapped_twice=duplicates.mapped_twice,
        landmarks_far=duplicates.far,
        revisits=len(truth.found),
        first_chance_m=_number(closure.first_chance_m),
        chance_error_m=_pose_error(wTr, anchored, gt.trajectory.se2, closure.first_chance_frame),
        chance_spread_m=_spread_m(estimate.pose_covariances, closure.first_chance_frame),
        closed_m=_number(closure.closed_m),
        closed_frame=-1 if closure.closed_frame is None else closure.closed_frame,
        revisits_reassociated=closure.closed_share,
        blind_end_m=truth.blind_end_m,
        after_blind_reassociated=closure.after_blind_share,
        cpu_s=math.nan if outcome.time is None else outcome.time.cpu_s,
    )


def _pose_error(wTr: np.ndarray, gtTest: np.ndarray, truth: np.ndarray, k: int | None) -> float:
    """Position error of frame k's pose, the estimate moved by ``gtTest`` [m] (NaN: no k)."""
    if k is None:
        return math.nan
    return float(np.linalg.norm(gtTest[:2, :2] @ wTr[k, :2] + gtTest[:2, 3] - truth[k, :2]))


def _spread_m(covariances: np.ndarray | None, k: int | None) -> float:
    """The estimate's position std at frame k, sqrt(var x + var y) [m] (NaN: none stated)."""
    if covariances is None or k is None:
        return math.nan
    return float(math.sqrt(max(covariances[k, 0, 0] + covariances[k, 1, 1], 0.0)))


def _number(value: float | None) -> float:
    return math.nan if value is None else float(value)


def _write_csv(path: Path, rows: list[Row]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=[f.name for f in fields(Row)])
        writer.writeheader()
        writer.writerows(asdict(r) for r in rows)


# -- the table ------------------------------------------------------------------------------
#: the table's columns: heading, Row field, format
COLUMNS = (
    ("ATE [m]", "ate_m", "{:.2f}"),
    ("end error [m]", "end_error_m", "{:.2f}"),
    ("error at the first revisit [m]", "chance_error_m", "{:.2f}"),
    ("its std [m]", "chance_spread_m", "{:.2f}"),
    ("error / std", "chance_sigmas", "{:.0f}"),
    ("landmark RMSE [m]", "landmark_rmse_m", "{:.2f}"),
    ("landmarks / pole", "landmarks_per_pole", "{:.2f}"),
    ("poles mapped twice", "poles_mapped_twice", "{:.0f}"),
    ("revisits re-associated", "revisits_reassociated", "{:.2f}"),
    ("after the blind stretch", "after_blind_reassociated", "{:.2f}"),
    ("CPU [s]", "cpu_s", "{:.0f}"),
)


def spread(values: Sequence[float], form: str) -> str:
    """``median [min-max]`` of the finite values (``-`` when there are none)."""
    finite = np.asarray([v for v in values if np.isfinite(v)], dtype=float)
    if not len(finite):
        return "-"
    middle = form.format(np.median(finite))
    if len(finite) == 1 or finite.min() == finite.max():
        return middle
    return f"{middle} [{form.format(finite.min())}-{form.format(finite.max())}]"


def markdown(rows: list[Row], configs: Sequence[Config], seeds: Sequence[int]) -> str:
    """Per route and odometry noise scale, one line per configuration: median [min-max] over
    the seeds, and on how many seeds the loop closed (a revisit re-associated) and where (median
    travel)."""
    lines = []
    scales = sorted({r.noise_scale for r in rows}, reverse=True)
    for route, scale in sorted({(r.route, r.noise_scale) for r in rows},
                               key=lambda rs: (rs[0], -rs[1])):
        noise = f", odometry noise {scale_text(scale)}" if scales != [1.0] else ""
        lines += [f"### Route {route}{noise} (seeds {_seed_text(seeds)})", ""]
        heads = ["configuration", "loop closed", "closed at [m]", *(c[0] for c in COLUMNS)]
        lines += ["| " + " | ".join(heads) + " |", "|" + "---|" * len(heads)]
        for config in configs:
            sel = [r for r in rows if r.route == route and r.noise_scale == scale
                   and r.config == config.label]
            if not sel:
                continue
            closed = [r.closed_m for r in sel if np.isfinite(r.closed_m)]
            cells = [config.label, f"{len(closed)}/{len(sel)}", spread(closed, "{:.0f}")]
            cells += [spread([getattr(r, name) for r in sel], form) for _, name, form in COLUMNS]
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def _seed_text(seeds: Sequence[int]) -> str:
    ordered = sorted(seeds)
    if ordered == list(range(ordered[0], ordered[-1] + 1)) and len(ordered) > 2:
        return f"{ordered[0]}-{ordered[-1]}"
    return ", ".join(map(str, ordered))


# -- the maps -------------------------------------------------------------------------------
def draw_maps(
    path: Path,
    route: int,
    seed: int,
    configs: Sequence[Config],
    cells_dir: Path,
    cells: Sequence[Cell],
    noise_scale: float = 1.0,
) -> None:
    """One panel per configuration as the thesis's Figs. 5.6 and 5.8: the occupancy grid of the
    180 deg laser built on the estimated trajectory (start anchored), its landmarks (circles)
    and the true poles (dots); the first panel is the truth. ``noise_scale``: the odometry
    noise's scale of the render (named in the title when it is not 1)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from omnislam.report.occupancy import occupancy_grid

    chosen = {c.estimator_label: c for c in cells
              if c.dataset_label == f"route{route}" and c.spec.seed == seed}
    records = [(c.label, read_run_dir(cells_dir / chosen[c.label].cell_id))
               for c in configs if c.label in chosen]
    if not records:
        return
    first = records[0][1]
    laser = load_dataset(resolve(first.config.dataset_path), {}).laser
    truth = first.ground_truth
    resolution = 0.05 if route == 1 else 0.2
    panels = [("truth", truth.trajectory.se2, truth.landmarks_w)]
    for label, record in records:
        T = ate(record.estimate.trajectory, truth.trajectory, Alignment.ORIGIN).gtTest
        poses = _transformed(record.estimate.trajectory.se2, T)
        panels.append((label, poses, _transformed_points(record.estimate.landmarks_w, T)))
    columns = min(4, len(panels))
    rows = math.ceil(len(panels) / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.4 * rows),
                                squeeze=False)
    for ax, (label, poses, landmarks) in zip(axes.flat, panels, strict=False):
        grid = occupancy_grid(laser.scanner_poses_w(poses), laser.angles_rad, laser.ranges_m,
                              laser.max_range_m, resolution_m=resolution)
        ax.imshow(grid.probability, origin="lower", cmap="gray_r", vmin=0, vmax=1,
                  extent=grid.extent_w, interpolation="none")
        ax.plot(poses[:, 0], poses[:, 1], lw=0.5, color="tab:blue")
        ax.scatter(truth.landmarks_w[:, 0], truth.landmarks_w[:, 1], s=2, c="k")
        ax.scatter(landmarks[:, 0], landmarks[:, 1], s=14, facecolors="none",
                   edgecolors="orange", linewidths=0.7)
        ax.set_title(label, fontsize=9)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=6)
    for ax in axes.flat[len(panels):]:
        ax.axis("off")
    noise = "" if noise_scale == 1 else f", odometry noise {scale_text(noise_scale)}"
    figure.suptitle(f"{ROUTES[route]}{noise}, seed {seed}: occupancy of the 180 deg laser on each "
                    "trajectory, landmarks (orange), true poles (black)", fontsize=10)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _transformed(wTr: np.ndarray, T: np.ndarray) -> np.ndarray:
    """(N, 3) planar poses moved by the (4, 4) transform T."""
    xy = wTr[:, :2] @ T[:2, :2].T + T[:2, 3]
    return np.column_stack([xy, wTr[:, 2] + math.atan2(T[1, 0], T[0, 0])])


def _transformed_points(points_w: np.ndarray, T: np.ndarray) -> np.ndarray:
    return points_w[:, :2] @ T[:2, :2].T + T[:2, 3]


if __name__ == "__main__":
    main()
