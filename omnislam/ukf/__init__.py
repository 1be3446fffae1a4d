"""omnislam.ukf: the vertical-line UKF localiser of Barra & Costa.

Modules: ``config`` (UKFConfig), ``image_line`` (the 1-D image, pixel thresholds as angles),
``photometric`` (PMC/MC, gate, C'_ij), ``candidates`` (landmarks in view), ``tracking``
(step 3), ``association`` (steps 4-5), ``filter`` (the pose UKF on filterpy), ``localiser``
(the Estimator), ``survey`` (the association's ground truth for benchmarks).
"""

from omnislam.ukf.config import AssociationConfig, PhotometricConfig, PhotometricMode, UKFConfig
from omnislam.ukf.factory import make_estimator
from omnislam.ukf.localiser import VerticalLineUKF

__all__ = [
    "AssociationConfig",
    "PhotometricConfig",
    "PhotometricMode",
    "UKFConfig",
    "VerticalLineUKF",
    "make_estimator",
]
