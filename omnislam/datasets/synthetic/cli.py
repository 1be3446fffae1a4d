"""``omnislam dataset synth PRESET --out DIR [--seed N] [--frames N] [--backend B]``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from omnislam.errors import ConfigError


def cli_synth(args: argparse.Namespace) -> int:
    """Render preset ``args.preset`` into ``args.out`` with a progress bar on stderr.

    ``args`` carries ``preset``, ``out``, ``seed`` (default 0), ``frames`` (None: all images),
    ``backend`` (None: open3d if installed) and optionally ``overwrite``. Returns the exit code.
    """
    from tqdm import tqdm

    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import prepare_output, write_synthetic

    preset = PRESETS.get(args.preset)
    if preset is None:
        raise ConfigError(f"unknown preset {args.preset!r}; known: {', '.join(PRESETS)}")
    overwrite = bool(getattr(args, "overwrite", False))
    prepare_output(Path(args.out), overwrite)
    seed = 0 if args.seed is None else int(args.seed)
    sim = simulate(preset, seed, max_images=args.frames, backend=args.backend)
    with tqdm(total=int(sim.image_frames.size), desc=f"synth {preset.name}", unit="img",
              file=sys.stderr, disable=None) as bar:
        def progress(count: int) -> None:
            bar.update(count - bar.n)

        write_synthetic(args.out, sim, backend=args.backend, overwrite=overwrite,
                        progress=progress)
    print(f"wrote {args.out}: {sim.stamps_s.size} frames, {sim.image_frames.size} images",
          file=sys.stderr)
    return 0
