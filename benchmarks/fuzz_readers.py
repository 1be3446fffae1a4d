"""The long run of the readers' mutation fuzzing: N mutated inputs across every reader.

The suite draws 30 mutations per reader (tests/datasets/test_fuzz_readers.py); this script
draws ``--examples`` in turn across the readers from a seeded generator and reports each
violation of the invariant (``tests/reader_fuzz.py``: sane output, or a DataError /
ConfigError naming the input, within the time limit) with the mutation that caused it.

    python benchmarks/fuzz_readers.py --examples 10000 [--seed 0] [--no-images]

Exit status 1 when any violation was found. 9-50 ms per example on the shared machine
(10 000: 1.5-9 min, idle or busy), plus ~20 s to build the inputs.
"""

from __future__ import annotations

import argparse
import collections
import logging
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from reader_fuzz import RandomChooser, build_targets, check


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--examples", type=int, default=10_000, help="mutated inputs in all")
    parser.add_argument("--seed", type=int, default=0, help="seed of the mutations")
    parser.add_argument("--no-images", action="store_true",
                        help="leave out the readers whose inputs need opencv (synthetic, camera)")
    args = parser.parse_args(argv)
    logging.disable(logging.WARNING)  # the readers' warnings about inputs they accept
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory(prefix="fuzz-readers-") as tmp:
        root = Path(tmp)
        targets = build_targets(root / "inputs", images=not args.no_images)
        names = sorted(targets)
        rng = np.random.default_rng(args.seed)
        counts: collections.Counter[str] = collections.Counter()
        violations: list[tuple[str, str, str]] = []
        start = time.perf_counter()
        for k in range(args.examples):
            name = names[k % len(names)]
            workdir = root / f"example-{k}"
            workdir.mkdir()
            outcome = check(targets[name], workdir, RandomChooser(rng))
            shutil.rmtree(workdir)
            counts[name] += 1
            if outcome.violation is not None:
                violations.append((name, outcome.mutation, outcome.violation))
        seconds = time.perf_counter() - start
    print(f"{args.examples} mutated inputs (seed {args.seed}) in {seconds:.0f} s:")
    for name in names:
        found = sum(1 for v in violations if v[0] == name)
        print(f"  {name:24s} {counts[name]:6d} inputs  {found} violations")
    for name, mutation, violation in violations:
        print(f"VIOLATION {name}: {mutation}: {violation}")
    print(f"{len(violations)} violations")
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
