"""Rendering speed of the synthetic omni renderer: frames/s per backend at 640x640.

    .venv/bin/python benchmarks/render.py [--preset demo] [--frames 10] [--supersample 1]
    .venv/bin/python benchmarks/render.py --full lab40      # whole preset to a temp folder

Reports the median time per frame (after one warm-up frame) for the numpy and open3d ray
casters side by side, and with --full the wall time of ``omnislam dataset synth``. The load
average is printed with the numbers: the machine is shared, so compare runs at similar load.
Targets: >= 10 fps with open3d, ``--full lab40`` in <= 2 minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from omnislam._optional import available
from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.simulate import simulate


def load_average() -> str:
    """The 1-, 5- and 15-minute load averages, as ``uptime`` prints them."""
    return ", ".join(f"{x:.2f}" for x in os.getloadavg())


def time_backend(sim, backend: str, supersample: int) -> float:
    """Median seconds per frame over the run's image frames after the first (warm-up)."""
    renderer = Renderer(sim.world, sim.rig, backend, supersample)
    renderer.render(sim.poses_w[sim.image_frames[0]])
    times = []
    for index in sim.image_frames[1:]:
        start = time.perf_counter()
        renderer.render(sim.poses_w[index])
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="demo")
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--supersample", type=int, default=1)
    parser.add_argument("--backends", default="numpy,open3d", help="comma-separated")
    parser.add_argument("--full", metavar="PRESET", help="time a whole synth run")
    args = parser.parse_args()
    print(f"load average before: {load_average()}")
    if args.full:
        from omnislam.datasets.synthetic.cli import cli_synth

        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            cli_synth(argparse.Namespace(preset=args.full, out=str(Path(tmp) / "out"), seed=0,
                                         frames=None, backend=None))
            print(f"{args.full}: full synth run {time.perf_counter() - start:.1f} s")
        print(f"load average after: {load_average()}")
        return
    print(f"{args.preset}: simulating the route and its laser ...", file=sys.stderr, flush=True)
    sim = simulate(PRESETS[args.preset], 0, max_images=args.frames + 1, backend="numpy")
    print(f"preset {args.preset}: {len(sim.world.quads)} quads, 640x640, "
          f"supersample {args.supersample}, median of {args.frames} frames")
    for backend in args.backends.split(","):
        if backend == "open3d" and not available("open3d"):
            print("open3d: not installed")
            continue
        print(f"{args.preset}: rendering {args.frames + 1} frames with {backend} ...",
              file=sys.stderr, flush=True)
        seconds = time_backend(sim, backend, args.supersample)
        print(f"{backend:>7}: {1000 * seconds:7.1f} ms/frame  {1 / seconds:5.1f} fps")
    print(f"load average after: {load_average()}")


if __name__ == "__main__":
    main()
