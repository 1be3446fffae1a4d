"""omnislam: compare SLAM back ends on one shared omnidirectional front end.

Subpackages (imports flow one way): ``core`` <- ``camera`` <- ``datasets``, ``frontend``
<- estimators (``graphslam``, ``fastslam``, ``ukf``, ``ekfslam``) <- ``compare`` <- ``cli``.
"""

__version__ = "0.1.0"
