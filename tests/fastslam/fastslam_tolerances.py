"""Tolerances of the FastSLAM tests (named in one place)."""

from __future__ import annotations

#: FastSLAM's ATE must be below this fraction of dead reckoning's on the loop scenario
ATE_FRACTION_OF_DEAD_RECKONING = 0.4
#: RMS landmark position error allowed on the loop scenario [m]
LANDMARK_RMSE_M = 1.5
#: absolute tolerance when comparing the tree and the dense store (same arithmetic)
STORE_ATOL = 1e-12
#: FastSLAM 2.0's ATE on the bearing-only loop with outlier tracks must be below this fraction
#: of dead reckoning's
ATE_FRACTION_OF_DEAD_RECKONING_3D = 0.5
#: fraction of bearing sightings whose track jumped to another point in the outlier scenario
OUTLIER_FRACTION = 0.05
