"""Whether two observation logs hold the same observations, array for array.

A change that is meant to leave the front end's output alone (a faster kernel, a different
process layout) is checked by writing the log with the code before and after it and comparing
every array the log file holds: bearings, their sigmas and ids, pixels, vertical lines and their
profiles, range-bearing sightings, odometry, stamps (NaN equals NaN). The run's statistics
(timings, CPU) are left out; the rest of the metadata is compared too::

    omnislam frontend runs/lab40 --out AFTER.npz      # and BEFORE.npz with the old code
    PYTHONPATH=. .venv/bin/python benchmarks/compare_logs.py BEFORE.npz AFTER.npz

Prints one line per differing array (or "identical") and exits 1 when anything differs.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def _meta(archive: np.lib.npyio.NpzFile) -> dict:
    meta = json.loads(str(archive["meta"]))
    meta.pop("stats", None)  # timings and CPU: not observations
    return meta


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", help="an observation log (.npz)")
    parser.add_argument("after", help="another observation log (.npz)")
    args = parser.parse_args()
    with np.load(args.before, allow_pickle=False) as a, np.load(args.after,
                                                                allow_pickle=False) as b:
        differing = sorted(set(a.files) ^ set(b.files))
        for key in sorted(set(a.files) & set(b.files)):
            if key == "meta":
                if _meta(a) != _meta(b):
                    differing.append("meta (other than its stats)")
                continue
            x, y = a[key], b[key]
            nan = x.dtype.kind == "f" and y.dtype.kind == "f"
            if x.shape != y.shape or not np.array_equal(x, y, equal_nan=nan):
                differing.append(key)
        total = len(set(a.files) | set(b.files))
    for key in differing:
        print(f"differs: {key}")
    if not differing:
        print(f"identical: {total} arrays (the run's stats aside)")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
