"""``omnislam dataset synth PRESET --out DIR [--seed N] [--frames N] [--image-every K]
[--backend B] [--realism clean|realistic]``."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from omnislam.errors import ConfigError


def cli_synth(args: argparse.Namespace) -> int:
    """Render preset ``args.preset`` into ``args.out``, its progress on stderr.

    ``args`` carries ``preset``, ``out``, ``seed`` (default 0), ``frames`` (None: all images),
    ``backend`` (None: open3d if installed) and optionally ``overwrite`` and ``image_every`` (one
    image every that many odometry steps instead of the preset's ``image_every_k``: the world,
    route, odometry and sightings are the same, only the image frames change) and ``realism``
    (``realism.Realism`` value; default clean). Returns the exit code.

    Raises:
        ConfigError: an unknown preset or realism, or an image step below 1.
    """
    from omnislam._progress import Progress
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.realism import Realism
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import prepare_output, write_synthetic

    preset = PRESETS.get(args.preset)
    if preset is None:
        raise ConfigError(f"unknown preset {args.preset!r}; known: {', '.join(PRESETS)}")
    image_every = getattr(args, "image_every", None)
    if image_every is not None:
        if image_every < 1:
            raise ConfigError(f"--image-every must be >= 1, got {image_every}")
        preset = dataclasses.replace(preset, image_every_k=int(image_every))
    realism = Realism.parse(getattr(args, "realism", None) or Realism.CLEAN, "--realism")
    overwrite = bool(getattr(args, "overwrite", False))
    prepare_output(Path(args.out), overwrite)
    seed = 0 if args.seed is None else int(args.seed)
    with Progress(f"synth {preset.name}", None, "frame") as stage:
        stage.update(doing="simulating the route, odometry, sightings and laser")
        sim = simulate(preset, seed, max_images=args.frames, backend=args.backend)
        stage.close(f"{sim.stamps_s.size} frames simulated")
    with Progress(f"synth {preset.name}", int(sim.image_frames.size), "img") as bar:
        def progress(count: int) -> None:
            bar.update(count, doing="rendering")

        write_synthetic(args.out, sim, backend=args.backend, overwrite=overwrite,
                        progress=progress, realism=realism)
    print(f"wrote {args.out}: {sim.stamps_s.size} frames, {sim.image_frames.size} images",
          file=sys.stderr)
    return 0
