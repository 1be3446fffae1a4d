"""Metrics: how far an estimate is from the ground truth, and the record of one run's numbers.

Modules: ``metrics`` (ATE with explicit alignment, RPE, landmark map error, NEES, step timing;
pure numpy/scipy), ``run_metrics`` (the RunMetrics record and ``metrics.json``), ``verdict``
(the best estimator of a dataset over seeds). Nothing here runs an estimator or reads a results
folder.
"""
