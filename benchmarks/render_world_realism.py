"""What each part of the rendered world's realism costs: render time per frame, part on vs off.

    nice -n 10 .venv/bin/python benchmarks/render_world_realism.py [--preset lab40] [--frames 8]

Renders the same frames of a preset (seed 0, evenly spread over its first ``--frames * 6``
images) clean, with each part of ``WorldRealism`` alone (lamps, imperfect rig, photographs,
walkers) and with all four, the renderers built once and the variants interleaved frame by
frame (so a change of the machine's load hits all alike). Prints the median CPU and wall time
per frame and their ratio to clean, with the load average: the machine is shared.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from omnislam.datasets.synthetic.lighting import LightingConfig
from omnislam.datasets.synthetic.photo_posters import PhotoTextures
from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.rig_error import RigError
from omnislam.datasets.synthetic.simulate import simulate
from omnislam.datasets.synthetic.walkers import Walkers
from omnislam.datasets.synthetic.world_realism import WorldRealism, draw_world_realism

VARIANTS = {
    "clean": WorldRealism(),
    "lighting": WorldRealism(lighting=LightingConfig()),
    "rig_error": WorldRealism(rig_error=RigError()),
    "photo_textures": WorldRealism(photo_textures=PhotoTextures()),
    "walkers": WorldRealism(walkers=Walkers()),
    "all four": WorldRealism.realistic(),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="lab40")
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--backend", default=None, help="open3d (default when installed), numpy")
    args = parser.parse_args()
    sim = simulate(PRESETS[args.preset], seed=0, max_images=args.frames * 6)
    frames = sim.image_frames[::6][:args.frames]
    renderers = {name: draw_world_realism(sim.world, realism, 0).renderer(sim.rig, args.backend)
                 for name, realism in VARIANTS.items()}
    cpu = {name: [] for name in VARIANTS}
    wall = {name: [] for name in VARIANTS}
    for renderer in renderers.values():  # warm-up
        renderer.render(sim.poses_w[frames[0]], float(sim.stamps_s[frames[0]]))
    for index in frames:
        for name, renderer in renderers.items():
            start_cpu, start_wall = time.process_time(), time.perf_counter()
            renderer.render(sim.poses_w[index], float(sim.stamps_s[index]))
            cpu[name].append(time.process_time() - start_cpu)
            wall[name].append(time.perf_counter() - start_wall)
    print(f"{args.preset}, {len(frames)} frames, load average "
          + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    print("| variant | CPU per frame [ms] | x clean | wall per frame [ms] | x clean |")
    print("|---|---|---|---|---|")
    cpu0, wall0 = np.median(cpu["clean"]), np.median(wall["clean"])
    for name in VARIANTS:
        c, w = np.median(cpu[name]), np.median(wall[name])
        print(f"| {name} | {1e3 * c:.0f} | {c / cpu0:.2f} | {1e3 * w:.0f} | {w / wall0:.2f} |")


if __name__ == "__main__":
    main()
