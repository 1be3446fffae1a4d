"""Presentation: reports, figures, tables and recordings of what the harness left on disk.

``report`` writes ``report.md`` and ``index.html`` from a results folder; ``plots`` draws its
figures, ``tables`` its tables (CSV, LaTeX), ``palette`` gives every estimator one colour,
``occupancy`` builds occupancy grids from laser scans, ``provenance`` says how a report was
made, ``view`` writes a Rerun recording of one RUN_DIR.
"""
