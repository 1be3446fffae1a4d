"""The declaration omnislam's registry reads through the entry point ``ekf-localiser``.

Only this module is imported when omnislam lists its estimators: the strings name where the
factory, the option check and the configuration live, imported when the estimator is used.
"""

from omnislam.core.modality import Modality
from omnislam.estimators import EstimatorEntry

ENTRY = EstimatorEntry(
    target="ekf_localiser.localiser:make_estimator",
    modalities=frozenset({Modality.RANGE_BEARING_2D}),
    check="ekf_localiser.localiser:check_options",
    summary="EKF localisation on range-bearing sightings in a known landmark map "
    "(Thrun et al. 2005 Table 7.2; a plugin: examples/estimator_plugin)",
    config="ekf_localiser.config:EKFLocaliserConfig",
)
