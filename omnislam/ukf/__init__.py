"""omnislam.ukf: the vertical-line UKF localiser of Barra & Costa.

Modules: ``config`` (UKFConfig and its sections), ``image_line`` (the 1-D image, pixel
thresholds as angles), ``photometric`` (PMC/MC, gate, C'_ij), ``candidates`` (landmarks in
view), ``tracking`` (step 3), ``association`` (steps 4-5), ``filter`` (the pose UKF on
filterpy), ``localiser`` (the Estimator), ``survey`` (the association's ground truth for
benchmarks).
"""

from omnislam.ukf.config import (
    AssociationConfig,
    FilterConfig,
    ImageConfig,
    PhotometricConfig,
    PhotometricMode,
    SigmaPointsConfig,
    SpacingConfig,
    TrackingConfig,
    UKFConfig,
)
from omnislam.ukf.factory import make_estimator
from omnislam.ukf.localiser import VerticalLineUKF

__all__ = [
    "AssociationConfig",
    "FilterConfig",
    "ImageConfig",
    "PhotometricConfig",
    "PhotometricMode",
    "SigmaPointsConfig",
    "SpacingConfig",
    "TrackingConfig",
    "UKFConfig",
    "VerticalLineUKF",
    "make_estimator",
]
