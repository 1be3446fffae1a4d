"""omnislam: compare SLAM back ends on one shared omnidirectional front end.

Subpackages (imports flow one way): ``core`` <- ``camera`` <- ``datasets``, ``frontend``
<- estimators (``graphslam``, ``fastslam``, ``ukf``, ``ekfslam``) <- ``metrics`` <- ``harness``
<- ``report`` <- ``demo`` <- ``cli``.
"""

__version__ = "0.2.0"
