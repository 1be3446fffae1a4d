"""GTSAM back end: iSAM2 (``graphslam``) and batch Levenberg-Marquardt (``graphslam-batch``).

Modules: ``config`` (the sectioned settings, kernels, factorisation), ``factors`` (noise models
and factors), ``levenberg_marquardt`` (the final LM solve), ``session`` (the iSAM2 session:
update with the QR fallback, reads; the omni fixed-lag session), ``poses`` (the pose chain:
Pose2 robot poses or Pose3 omni viewpoints), one graph builder per modality (``bearings_3d``,
``range_bearing``, ``vertical_lines``; shared parts in ``builder``), ``landmark_init`` (delayed
insertion of bearing-only tracks), ``outlier_gate`` (sightings of mapped landmarks),
``association`` / ``window_association`` / ``nearest_association`` (unlabelled range-bearing
sightings), ``tentative`` (landmarks the association holds back until re-observed),
``loop_closure`` (duplicated landmarks merged), ``floor_scale`` / ``floor_points`` /
``odometry_scale`` (the odometry's metric scale from the floor), ``isam`` (the incremental
estimator), ``batch`` (LM warm-started from it), ``reassociation``, ``export`` (g2o).

gtsam is imported lazily: ``import omnislam.graphslam`` works without it, and the estimator
classes raise an error naming the ``graph`` extra when it is missing.
"""

from __future__ import annotations

from typing import Any

from omnislam.graphslam.config import Factorization, GraphSLAMConfig, RobustKernel

__all__ = [
    "BatchGraphSLAM",
    "Factorization",
    "GraphSLAM",
    "GraphSLAMConfig",
    "RobustKernel",
]


def __getattr__(name: str) -> Any:
    if name == "GraphSLAM":
        from omnislam.graphslam.isam import GraphSLAM

        return GraphSLAM
    if name == "BatchGraphSLAM":
        from omnislam.graphslam.batch import BatchGraphSLAM

        return BatchGraphSLAM
    if name in ("make_estimator", "make_batch_estimator"):
        from omnislam.graphslam import factory

        return getattr(factory, name)
    raise AttributeError(f"module 'omnislam.graphslam' has no attribute {name!r}")
