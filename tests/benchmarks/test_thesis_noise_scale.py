"""``benchmarks/thesis.py --noise-scale``: the thesis presets with their odometry's alpha
coefficients scaled. The scaled preset's odometry carries the scaled noise (the same draws,
scaled), everything else is the registered preset's, and scale 1 is the registered preset and
its render in the harness's cache, unchanged."""

from __future__ import annotations

import importlib.util
import sys
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

from omnislam.core.motion import OdometryMotionModel
from omnislam.datasets.synthetic.presets import PRESETS, THESIS_MOTION_NOISE
from omnislam.datasets.synthetic.simulate import drive
from omnislam.harness.cache import cache_dir
from omnislam.harness.renders import RENDERS, render_spec

REPO = Path(__file__).resolve().parents[2]


def _load(name: str) -> object:
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, REPO / "benchmarks" / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


_load("thesis_metrics")
thesis = _load("thesis")

#: the alpha coefficients of thesis eq. 4.40
ALPHAS = ("a_vv", "a_vw", "a_wv", "a_ww")
#: a step shorter than this is the robot standing still, where the stds' floor binds [m]
MOVING_M = 0.01


@pytest.mark.parametrize("name", ["thesis-route1", "thesis-route2"])
@pytest.mark.parametrize("scale", [0.25, 0.5, 2.0])
def test_scaled_preset_scales_the_alphas_only(name: str, scale: float) -> None:
    registered, scaled = PRESETS[name], thesis.scaled_preset(name, scale)
    for alpha in ALPHAS:
        expected = scale * getattr(THESIS_MOTION_NOISE, alpha)
        assert getattr(scaled.motion_noise, alpha) == pytest.approx(expected, rel=1e-12)
    assert scaled.motion_noise.min_sigma == registered.motion_noise.min_sigma
    assert scaled.motion_noise.reference_step_m == registered.motion_noise.reference_step_m
    assert scaled.name == f"{name}-x{scale:g}"
    unchanged = {"name", "description", "motion_noise"}
    for f in fields(registered):
        if f.name not in unchanged:
            assert getattr(scaled, f.name) == getattr(registered, f.name), f.name


def test_scaled_odometry_is_the_same_draw_scaled() -> None:
    """Half the alphas: every moving step's error in (rot1, trans, rot2) is half the registered
    preset's error of the same seed; the true route is the same."""
    name, seed = "thesis-route1", 3
    full, half = drive(PRESETS[name], seed), drive(thesis.scaled_preset(name, 0.5), seed)
    np.testing.assert_array_equal(half.poses_w, full.poses_w)
    model = OdometryMotionModel(THESIS_MOTION_NOISE)
    true = model.decompose(full.odometry_true_r[1:])
    moving = true[:, 1] > MOVING_M
    error_full = model.decompose(full.odometry_r[1:])[moving] - true[moving]
    error_half = model.decompose(half.odometry_r[1:])[moving] - true[moving]
    assert moving.sum() > 1000
    assert np.abs(error_full).max() > 1e-3  # the noise is there to scale
    np.testing.assert_allclose(error_half, 0.5 * error_full, rtol=1e-6, atol=1e-9)


def test_scale_one_is_the_registered_render() -> None:
    for name in ("thesis-route1", "thesis-route2"):
        assert thesis.scaled_preset(name, 1.0) is PRESETS[name]
        spec = thesis.scaled_render(name, 1.0, 4)
        assert spec == render_spec(name, 4)
        assert spec.path() == cache_dir() / RENDERS / render_spec(name, 4).folder_name


def test_a_scaled_render_is_the_registered_folder_with_the_scale_named(tmp_path: Path) -> None:
    registered, scaled = render_spec("thesis-route1", 2), thesis.scaled_render(
        "thesis-route1", 0.5, 2)
    assert scaled.key == registered.key
    assert scaled.folder_name == registered.folder_name.replace(
        "thesis-route1-s2", "thesis-route1-x0.5-s2")
    assert scaled.path(tmp_path).parent == tmp_path


def test_scale_one_grid_is_the_registered_presets_grid(tmp_path: Path) -> None:
    """At scale 1 the experiment is one grid over the registered presets, whose cells render
    into the harness's cache and run with each seed."""
    configs = [c for c in thesis.CONFIGS if c.label in ("fs1-50", "deadreckoning")]
    (experiment,) = thesis.experiments(tmp_path, [1, 2], [0, 3], configs, 1.0)
    assert experiment.results_dir == tmp_path / "runs"
    assert {c.render for c in experiment.grid.cells} == {
        render_spec(f"thesis-route{r}", s) for r in (1, 2) for s in (0, 3)}
    assert {(c.dataset_label, c.estimator_label, c.spec.seed) for c in experiment.grid.cells} == {
        (f"route{r}", c.label, s) for r in (1, 2) for c in configs for s in (0, 3)}
