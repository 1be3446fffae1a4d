"""Tolerances of the core tests, named in one place."""

#: relative error allowed between an analytic and a central-difference Jacobian
JACOBIAN_RTOL = 1e-6
#: relative error allowed between sample moments of 100k draws and the linearised moments
MOMENT_RTOL = 0.02
