"""The vertical-line UKF on MR.CLAM dataset 6 with the sightings' ids, at its defaults: a guard
on its accuracy on real data (docs/results/ukf.md, "MR.CLAM").

The figure the UKF was accepted with, 0.077 m, is the median over robots 1-5 of each run's
*median* position error; ``omnislam run`` prints the RMSE (0.118 m over the same robots), which
the long tail of robot 4's stretches without a sighting weighs more. Both are guarded here.
"""

from __future__ import annotations

import statistics

import pytest

from omnislam.cli import main
from omnislam.metrics.run_metrics import read_run_metrics

#: the median over the robots of the per-robot median ATE [m] (0.078 measured)
MEDIAN_OF_MEDIANS_MAX_M = 0.10
#: the median over the robots of the per-robot ATE RMSE [m] (0.118 measured)
MEDIAN_OF_RMSE_MAX_M = 0.13
#: robot 3: a misread barcode 3.0 rad off its landmark threw the pose 5 m without the outlier
#: gate (median ATE 0.71 m); 0.049 m measured with it
ROBOT3_MEDIAN_MAX_M = 0.08


def _ukf_ate(robot: int, out) -> tuple[float, float]:
    """(median, RMSE) ATE [m] of the UKF at its defaults on MR.CLAM 6 robot ``robot``."""
    assert main(["run", f"mrclam6-r{robot}", "--estimator", "ukf", "--out", str(out)]) == 0
    assert main(["evaluate", str(out)]) == 0
    ate = read_run_metrics(out / "metrics.json").ate
    return ate.median_m, ate.rmse_m


def test_the_outlier_gate_keeps_a_misread_barcode_from_throwing_robot_3(shared_data, tmp_path):
    median_m, _ = _ukf_ate(3, tmp_path / "r3")
    assert median_m <= ROBOT3_MEDIAN_MAX_M


@pytest.mark.slow
def test_robots_1_to_5_stay_at_the_accuracy_the_ukf_was_accepted_with(shared_data, tmp_path):
    runs = [_ukf_ate(robot, tmp_path / f"r{robot}") for robot in range(1, 6)]
    assert statistics.median(m for m, _ in runs) <= MEDIAN_OF_MEDIANS_MAX_M
    assert statistics.median(r for _, r in runs) <= MEDIAN_OF_RMSE_MAX_M
