"""FastSLAM 1.0 / 2.0 with the thesis's shared landmark tree (Guizilini 2008 sec. 4.4).

``FastSLAM(config, rng, initial_pose)`` implements the ``Estimator`` protocol; its name is
``config.variant.value`` ("fastslam1" or "fastslam2").
"""

from omnislam.fastslam.config import (
    PRESETS,
    BearingUpdate,
    ExistenceIndexConfig,
    FastSLAMConfig,
    ResamplingScheme,
    SensorMode,
    StoreKind,
    TrajectoryMode,
    TriangulationMethod,
    Variant,
)
from omnislam.fastslam.dense_store import DenseLandmarkStore
from omnislam.fastslam.factory import make_fastslam1, make_fastslam2
from omnislam.fastslam.filter import FastSLAM, make_store
from omnislam.fastslam.landmark_store import LandmarkBlock, LandmarkStatus, LandmarkStore
from omnislam.fastslam.landmark_tree import LandmarkTree, TreeLayout

__all__ = [
    "PRESETS",
    "BearingUpdate",
    "DenseLandmarkStore",
    "ExistenceIndexConfig",
    "FastSLAM",
    "FastSLAMConfig",
    "LandmarkBlock",
    "LandmarkStatus",
    "LandmarkStore",
    "LandmarkTree",
    "ResamplingScheme",
    "SensorMode",
    "StoreKind",
    "TrajectoryMode",
    "TreeLayout",
    "TriangulationMethod",
    "Variant",
    "make_fastslam1",
    "make_fastslam2",
    "make_store",
]
