"""Configuration of the EKF localiser: one frozen dataclass with a motion section."""

from __future__ import annotations

from dataclasses import dataclass, field

from omnislam.core.motion import MotionNoise
from omnislam.errors import ConfigError


@dataclass(frozen=True, slots=True)
class EKFLocaliserConfig:
    """EKF localisation in a prior map (``--set KEY=VALUE`` sets each field).

    Attributes:
        motion_noise: alpha coefficients of omnislam's odometry model (thesis eqs. 4.40-4.41),
            used when the odometry states no covariance of its own. Default: core's
            ``MotionNoise()``, the model every built-in filter starts from.
        initial_sigma_xy_m: standard deviation of the start pose's x and y [m]. Default 0.1:
            the prior map's initial pose is a measured one (MR.CLAM: Vicon), not exact.
        initial_sigma_theta_rad: standard deviation of the start pose's heading [rad].
            Default 0.1 (about 6 degrees), for the same reason.
        gate_probability: a sighting whose innovation's squared Mahalanobis distance exceeds
            the chi-square quantile of this probability (2 degrees of freedom) is rejected as
            an outlier. Default 0.999: a consistent filter loses one sighting in a thousand.
    """

    motion_noise: MotionNoise = field(default_factory=MotionNoise)
    initial_sigma_xy_m: float = 0.1
    initial_sigma_theta_rad: float = 0.1
    gate_probability: float = 0.999

    def __post_init__(self) -> None:
        if not (self.initial_sigma_xy_m > 0 and self.initial_sigma_theta_rad > 0):
            raise ConfigError("ekf-localiser: the initial sigmas must be positive")
        if not 0 < self.gate_probability <= 1:
            raise ConfigError("ekf-localiser: gate_probability must be in (0, 1]")
