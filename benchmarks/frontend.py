"""Benchmark of the shared front end: speed and quality against the renderer's ground truth.

Usage and what it reports: ``benchmarks/_frontend_benchmark.py`` (``--help``).

The benchmark lives there because the front end's worker processes import this script again
(multiprocessing imports a parent's main module in its children; ``pipeline``'s fork server
does it once for its workers): here it costs them nothing, as it costs nothing under
``omnislam frontend``, so the speed measured is the command's.
"""

if __name__ == "__main__":
    import sys

    from _frontend_benchmark import main

    sys.exit(main())
