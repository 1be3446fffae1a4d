"""The harness: runs estimators on datasets and writes what they leave on disk.

One run (``execute``: ``omnislam run``) and a grid of them (``grid``, ``runner``: ``omnislam
compare``), what a run writes (``rundir``) and how it is scored (``evaluation``), the faults it
can inject (``perturb``), the reference solutions of data without ground truth (``reference``),
synthetic renders made on demand (``renders``, ``code_closure``), the cache (``cache``), the
workers' progress (``channel``, ``grid_progress``) and prior maps from earlier runs (``prior``).
"""
