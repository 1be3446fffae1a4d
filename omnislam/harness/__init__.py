"""The harness: runs estimators on datasets and writes what they leave on disk.

One run (``execute``: ``omnislam run``): its options split by who takes them, the frames the
estimator is fed (``frames``: a front-end log replayed, with the faults of ``perturb``), the
ground truth it is scored against (``reference``: reference solutions of data without ground
truth; ``track_truth``: the true points of a log's tracks), prior maps from earlier runs
(``prior``). A grid of runs (``grid``, ``runner``: ``omnislam compare``) with synthetic renders
made on demand (``renders``, ``code_closure``), the cache (``cache``) and the workers' progress
(``channel``, ``grid_progress``). What a run leaves on disk (``rundir``; the file names of a
RUN_DIR and of a results folder in ``layout``, which the report reads too) and how it is scored
(``evaluation``).
"""
