"""Tolerances of the core tests, named in one place."""

#: relative error allowed between an analytic and a central-difference Jacobian
JACOBIAN_RTOL = 1e-6
#: relative error allowed between sample moments of 100k draws and the linearised moments
MOMENT_RTOL = 0.02
#: UKF vs EKF from core's Jacobians on a nearly linear problem: pose mean [m or rad]
UKF_EKF_MEAN_ATOL = 1e-4
#: ... and covariance, relative to the EKF's
UKF_EKF_COV_RTOL = 0.02
#: the UKF without vision departs from dead reckoning by the unscented transform's second-order
#: term only: at most this fraction of the position std
UKF_DR_FRACTION_OF_SIGMA = 0.1
