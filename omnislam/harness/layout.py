"""The file names of what the harness leaves on disk, in the one module both sides read.

The harness writes a RUN_DIR (``rundir.write_run_dir``: ``omnislam run`` and every cell of a
grid; its files are described there) and a results folder (``runner.run_grid``: ``omnislam
compare``); ``omnislam evaluate``, the report and the recording read them by these names::

    RESULTS_DIR/
      grid.yaml            the grid as given (marks the folder as a results folder)
      logs/                the shared front end's log of each dataset with images or scans
      cells/CELL_ID/       one RUN_DIR per cell, with metrics.json and cell_time.json
      results.json         one row per cell: labels, status, error, metrics, cell time
      results.csv          the same rows as a table
"""

from __future__ import annotations

# -- a RUN_DIR -------------------------------------------------------------------------------
#: one estimated pose per frame (TUM)
TRAJECTORY = "trajectory.tum"
#: the estimated map, ``id,x,y,z``
LANDMARKS = "landmarks.csv"
#: the wall time of each estimator step, ``frame,stamp_s,step_s``
TIMING = "timing.csv"
#: what was run (``rundir.RunConfig``); its presence marks a folder as a RUN_DIR
CONFIG = "config.yaml"
#: the sequence's ground truth, copied at run time when it has any
GROUND_TRUTH = "ground_truth.tum"
GROUND_TRUTH_LANDMARKS = "ground_truth_landmarks.csv"
#: the run's metrics (``metrics.run_metrics``), written by ``omnislam evaluate`` and the runner
METRICS = "metrics.json"
#: covariances, when the estimator gives them
POSE_COVARIANCES = "pose_covariances.csv"
LANDMARK_COVARIANCES = "landmark_covariances.csv"
#: attachment an estimator with a factor graph exports (core.types.Exporting: graphslam)
GRAPH_G2O = "graph.g2o"
#: the counts an estimator's ``info()`` reports at the end of the run (core.types.Introspectable)
ESTIMATOR_INFO = "estimator_info.json"
#: file names an attachment may take (kept small so a RUN_DIR stays a known set of files)
ATTACHMENTS = (GRAPH_G2O, ESTIMATOR_INFO)

# -- a results folder ------------------------------------------------------------------------
#: the grid as given; its presence marks a folder as a results folder
GRID_COPY = "grid.yaml"
#: sub-folder of front-end logs (in a results folder, and in the cache: ``cache.cache_dir``)
LOGS = "logs"
#: sub-folder of the cells' RUN_DIRs
CELLS = "cells"
RESULTS_JSON = "results.json"
RESULTS_CSV = "results.csv"
#: a cell folder's cost on its worker (``runner.CellTime``)
CELL_TIME = "cell_time.json"
