"""EKF-SLAM, the baseline of "SLAM for Dummies" (Riisgaard & Blas; SEEDS.md sec. 3).

``EKFSLAM(config, motion, initial_pose_w)`` implements the ``Estimator`` protocol (and ``info()``)
for 2-D range-bearing sightings with known or unknown ids; ``BearingEKFSLAM`` for the omni
camera's bearings (3-D landmarks by delayed triangulation). Modules: ``state`` (the joint
Gaussian and its O(n) prediction, O(n^2) sparse update, augmentation), ``association`` (nearest
neighbour, validation gate, tentative landmarks), ``bearings`` (the omni filter), ``config``
(EKFSLAMConfig and its sections), ``filter``, ``factory``.
"""

from omnislam.ekfslam.bearings import BearingEKFSLAM
from omnislam.ekfslam.config import (
    AssociationConfig,
    AssociationTest,
    BearingsConfig,
    EKFSLAMConfig,
    ExperimentalConfig,
    LandmarksConfig,
    OutlierGateConfig,
    StateConfig,
)
from omnislam.ekfslam.factory import make_estimator
from omnislam.ekfslam.filter import EKFSLAM, EKFSLAMInfo
from omnislam.ekfslam.state import SlamGaussian

__all__ = [
    "EKFSLAM",
    "AssociationConfig",
    "AssociationTest",
    "BearingEKFSLAM",
    "BearingsConfig",
    "EKFSLAMConfig",
    "EKFSLAMInfo",
    "ExperimentalConfig",
    "LandmarksConfig",
    "OutlierGateConfig",
    "SlamGaussian",
    "StateConfig",
    "make_estimator",
]
