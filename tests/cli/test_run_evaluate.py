"""``omnislam run`` / ``omnislam evaluate`` / ``omnislam dataset list`` end to end."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from omnislam.cli import main
from omnislam.datasets.registry import REGISTRY
from omnislam.harness.rundir import read_run_dir
from omnislam.metrics.run_metrics import read_run_metrics
from omnislam.metrics.trajectory import Alignment

#: dead-reckoning ATE (SE(2) aligned) of each loader's data: a regression guard
DEAD_RECKONING_ATE_M = {
    "mrclam6-r1": 2.06,
    "victoria-park": 92.9,
    "carmen-intel": 23.4,
    "carmen-aces": 5.42,
}


#: datasets whose evaluation first computes its reference (the LM optimum of gtsam's whole
#: victoria_park.txt: minutes): in ``make test-all``
_REFERENCE_COMPUTED = {"victoria-park-gtsam"}


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n in _REFERENCE_COMPUTED else n for n in REGISTRY],
)
def test_dead_reckoning_runs_on_every_registered_dataset(name, tmp_path, capsys):
    if not REGISTRY[name].found():
        pytest.skip(f"{name} not found at {REGISTRY[name].location()}")
    out = tmp_path / "run"
    assert (
        main(["run", name, "--estimator", "deadreckoning", "--out", str(out), "--seed", "1"]) == 0
    )
    assert {p.name for p in out.iterdir()} >= {
        "trajectory.tum",
        "landmarks.csv",
        "timing.csv",
        "config.yaml",
    }
    config = yaml.safe_load((out / "config.yaml").read_text())
    assert config["dataset"] == name and config["estimator"] == "deadreckoning"
    assert config["seed"] == 1 and config["omnislam_version"]
    assert main(["evaluate", str(out), "--json"]) == 0
    metrics = read_run_metrics(out / "metrics.json")
    record = read_run_dir(out)
    assert metrics.timing.frames == len(record.estimate.trajectory) == len(record.step_s)
    if record.ground_truth.trajectory is None:
        assert metrics.ate.rmse_m is None and metrics.ground_truth.alignment is None
        assert main(["evaluate", str(out)]) == 0
        assert "no ground truth" in capsys.readouterr().out
    else:
        assert metrics.ground_truth.alignment is Alignment.SE2
        assert metrics.ate.origin_rmse_m >= metrics.ate.rmse_m > 0
        if name in DEAD_RECKONING_ATE_M:
            assert metrics.ate.rmse_m == pytest.approx(DEAD_RECKONING_ATE_M[name], rel=0.01)


def write_raw_carmen(path: Path, stamps=(1.0, 2.0, 3.0)) -> Path:
    lines = [f"FLASER 2 1 1 0 0 0 {k * 0.5} 0 {k * 0.1} {t} h {t}\n" for k, t in enumerate(stamps)]
    path.write_text("".join(lines))
    return path


def test_run_on_a_path_and_rerun_replaces_the_run_dir(tmp_path, capsys):
    log = write_raw_carmen(tmp_path / "mine.log")
    out = tmp_path / "run"
    argv = ["run", str(log), "--estimator", "deadreckoning", "--out", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    assert main(argv) == 2  # the one overwrite rule: an existing RUN_DIR needs --overwrite
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--overwrite" in err and str(out) in err
    assert main([*argv, "--overwrite"]) == 0
    record = read_run_dir(out)
    assert np.allclose(record.estimate.trajectory.se2[-1], [1.0, 0.0, 0.2], atol=0.06)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
    assert main(["evaluate", str(out)]) == 0
    assert "no ground truth" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--estimator", "kalman"], "unknown estimator 'kalman'"),
        (["--estimator", "deadreckoning", "--set", "particles=3"], "takes no options"),
        (["--estimator", "deadreckoning", "--set", "oops"], "expects KEY=VALUE"),
        (["--estimator", "deadreckoning", "--log", "missing.npz"], "missing.npz"),
    ],
)
def test_bad_arguments_exit_2_without_output(tmp_path, capsys, extra, message):
    log = write_raw_carmen(tmp_path / "mine.log")
    out = tmp_path / "run"
    assert main(["run", str(log), "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_bad_data_exits_2_naming_file_and_line(tmp_path, capsys):
    log = write_raw_carmen(tmp_path / "mine.log", stamps=(1.0, 20.0, 3.0))
    out = tmp_path / "run"
    assert main(["run", str(log), "--estimator", "deadreckoning", "--out", str(out)]) == 2
    assert f"{log}: line 3:" in capsys.readouterr().err
    assert not out.exists() and len(list(tmp_path.iterdir())) == 1


def test_a_crash_during_the_run_leaves_no_run_dir(tmp_path, monkeypatch, capsys):
    import omnislam.deadreckoning as dr

    def boom(self, frame):
        raise RuntimeError("estimator crashed")

    monkeypatch.setattr(dr.DeadReckoning, "step", boom)
    log = write_raw_carmen(tmp_path / "mine.log")
    out = tmp_path / "run"
    assert main(["run", str(log), "--estimator", "deadreckoning", "--out", str(out)]) == 1
    assert not out.exists()
    err = capsys.readouterr().err.strip().splitlines()  # a bug: one line, exit 1
    assert len(err) == 1 and "internal error" in err[0] and "estimator crashed" in err[0]
    assert not any(p.name.startswith(".run.") for p in tmp_path.iterdir())


def test_refuses_to_overwrite_a_folder_that_is_not_a_run_dir(tmp_path, capsys):
    log = write_raw_carmen(tmp_path / "mine.log")
    out = tmp_path / "precious"
    out.mkdir()
    (out / "thesis.tex").write_text("x")
    assert main(["run", str(log), "--estimator", "deadreckoning", "--out", str(out)]) == 2
    assert "refusing to overwrite" in capsys.readouterr().err
    assert (out / "thesis.tex").exists()


def test_evaluate_on_a_non_run_dir_exits_2(tmp_path, capsys):
    assert main(["evaluate", str(tmp_path)]) == 2
    assert "not a RUN_DIR" in capsys.readouterr().err


def test_dataset_list_shows_where_it_looked(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("OMNISLAM_DATA", str(tmp_path))
    assert main(["dataset", "list"]) == 0
    out = capsys.readouterr().out
    assert "mrclam6-r1" in out and "NO" in out and str(tmp_path) in out
    assert main(["dataset", "list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {"name", "source", "sensors", "ground_truth", "found", "location"} <= set(rows[0])


def test_provenance_credits_the_published_dataset_only_when_it_was_named(
    tmp_path, monkeypatch, capsys, shared_data
):
    from small_mrclam import write_small_mrclam

    monkeypatch.setenv("OMNISLAM_DATA", str(shared_data))
    monkeypatch.chdir(tmp_path)
    write_small_mrclam(tmp_path / "MRCLAM_Mine")
    for dataset, run in (("MRCLAM_Mine", "mine"), ("mrclam6-r1", "published")):
        assert main(["run", dataset, "--estimator", "deadreckoning", "--out", run]) == 0
    mine = yaml.safe_load((tmp_path / "mine" / "config.yaml").read_text())
    assert mine["source"] == "a folder in MR.CLAM format at MRCLAM_Mine"
    published = yaml.safe_load((tmp_path / "published" / "config.yaml").read_text())
    assert "UTIAS" in published["source"] and "Leung" in published["source"]
    assert mine["seed"] == published["seed"] == 0  # the default seed, recorded

    for run in ("mine", "published"):
        argv = ["report", run, "--out", f"report-{run}", "--no-exports", "--no-figures"]
        assert main(argv) == 0
    capsys.readouterr()
    own = (tmp_path / "report-mine" / "report.md").read_text()
    assert "a folder in MR.CLAM format at MRCLAM_Mine" in own and "UTIAS" not in own
    cited = (tmp_path / "report-published" / "report.md").read_text()
    assert "mrclam6-r1: UTIAS MR.CLAM: Leung" in cited


@pytest.mark.slow
def test_run_renders_a_synthetic_preset_on_demand_into_the_cache(tmp_path, capsys):
    pytest.importorskip("cv2")
    from omnislam.harness.cache import cache_dir
    from omnislam.harness.renders import render_spec

    argv = ["run", "thesis-route1", "--estimator", "deadreckoning", "--seed", "3"]
    assert main([*argv, "--out", str(tmp_path / "a")]) == 0
    config = yaml.safe_load((tmp_path / "a" / "config.yaml").read_text())
    render = render_spec("thesis-route1", 3).path()
    assert render.is_dir() and cache_dir() in render.parents
    assert config["dataset"] == str(render.absolute()) and config["seed"] == 3
    assert config["source"].startswith("synthetic preset thesis-route1 (seed 3)")
    assert "rendered thesis-route1 (seed 3)" in capsys.readouterr().err
    before = render.stat().st_mtime_ns
    assert main([*argv, "--out", str(tmp_path / "b")]) == 0  # the second run reuses the render
    assert "rendered" not in capsys.readouterr().err and render.stat().st_mtime_ns == before
    first, second = ((tmp_path / r / "trajectory.tum").read_bytes() for r in "ab")
    assert first == second
