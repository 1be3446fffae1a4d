"""Presentation: reports, figures, tables and recordings of what the harness left on disk.

``comparison.write_report`` writes ``report.md`` and ``index.html`` from a results folder: it
reads the runs (``results``), builds the report once as typed sections (``model``,
``sections``: the tables of ``metric_tables``, the figures of ``figures`` drawn by ``plots``,
the provenance block of ``provenance``), writes the exports (``exports``) and renders the model
to Markdown and to HTML (``render``); ``options`` says what it includes, ``tables`` writes each
table as CSV and LaTeX, ``palette`` gives every estimator one colour, ``occupancy`` builds
occupancy grids from laser scans. ``view`` writes a Rerun recording of one RUN_DIR. Nothing
here runs an estimator: the report reads the harness's file layout, RUN_DIRs and evaluation
only (``tests/test_layers.py``).
"""
