"""Metrics: how far an estimate is from the ground truth, and the record of one run's numbers.

Modules, one concept each (pure numpy/scipy): ``trajectory`` (ATE with explicit alignment,
stamp association, RPE), ``landmarks`` (landmark map error), ``consistency`` (NEES),
``timing`` (step time statistics); ``run_metrics`` (the RunMetrics record and its
``metrics.json``), ``verdict`` (the best estimator of a dataset over seeds). Nothing here runs
an estimator or reads a results folder.
"""
