"""EKF localisation in a known landmark map: an omnislam estimator plugin.

``plugin.ENTRY`` is what omnislam's registry reads (the entry point in pyproject.toml);
``config`` holds the configuration dataclass, ``localiser`` the filter and its factory. The
filter is built from omnislam's shared models: the odometry motion model of ``core.motion`` (or
the odometry's own stated covariance), the range-bearing model of ``core.measurement``, the
Kalman update of ``core.kalman`` and the chi-square gate of ``core.gating``.
"""
