"""FastSLAM 1.0 / 2.0 with the thesis's shared landmark tree (Guizilini 2008 sec. 4.4).

``FastSLAM(config, rng, modality=..., motion=...)`` implements the ``Estimator`` and
``Introspectable`` protocols; ``make_fastslam(config, modality, rng)`` builds its motion model
from the configuration. Its name is ``config.variant.value`` ("fastslam1" or "fastslam2"). The
configuration is a tree of sections (``FastSLAMConfig``: ``particles``, ``resampling``,
``association``, ``proposal``, ``bearings``, ``existence``, ``experimental``).
"""

from omnislam.fastslam.config import (
    PRESETS,
    AssociationConfig,
    BearingsConfig,
    BearingUpdate,
    ExistenceIndexConfig,
    ExperimentalConfig,
    FastSLAMConfig,
    Kernels,
    ParticlesConfig,
    ProposalConfig,
    ProposalUpdateMode,
    ResamplingConfig,
    ResamplingScheme,
    StatedOdometryNoise,
    StoreKind,
    TrajectoryMode,
    TriangulationMethod,
    Variant,
)
from omnislam.fastslam.dense_store import DenseLandmarkStore
from omnislam.fastslam.factory import make_fastslam, make_fastslam1, make_fastslam2
from omnislam.fastslam.filter import FastSLAM, make_store
from omnislam.fastslam.info import FastSLAMInfo
from omnislam.fastslam.landmark_store import LandmarkBlock, LandmarkStatus, LandmarkStore
from omnislam.fastslam.landmark_tree import LandmarkTree, TreeLayout
from omnislam.fastslam.mapper import MODALITIES

__all__ = [
    "MODALITIES",
    "PRESETS",
    "AssociationConfig",
    "BearingUpdate",
    "BearingsConfig",
    "DenseLandmarkStore",
    "ExistenceIndexConfig",
    "ExperimentalConfig",
    "FastSLAM",
    "FastSLAMConfig",
    "FastSLAMInfo",
    "Kernels",
    "LandmarkBlock",
    "LandmarkStatus",
    "LandmarkStore",
    "LandmarkTree",
    "ParticlesConfig",
    "ProposalConfig",
    "ProposalUpdateMode",
    "ResamplingConfig",
    "ResamplingScheme",
    "StatedOdometryNoise",
    "StoreKind",
    "TrajectoryMode",
    "TreeLayout",
    "TriangulationMethod",
    "Variant",
    "make_fastslam",
    "make_fastslam1",
    "make_fastslam2",
    "make_store",
]
