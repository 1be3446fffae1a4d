"""When to resample the particles, and the resampling of their poses, maps and history.

After each update with sightings the particle set is resampled when its effective sample size
(thesis eq. 4.51) falls below a fraction of P (sec. 4.4.2.3), with the configured scheme
(``resampling``: low-variance systematic by default, Thrun et al. 2005 Table 4.4); poses and
maps follow the ancestors (the landmark store copies maps by reference or by value), and the
path history records them. With islands (``ExperimentalConfig.islands``) each island is
resampled apart from its own weights (``resampling.island_resample``).
"""

from __future__ import annotations

import numpy as np

from omnislam.fastslam.config import ResamplingConfig, ResamplingScheme
from omnislam.fastslam.landmark_store import LandmarkStore
from omnislam.fastslam.particles import ParticleSet, PathHistory
from omnislam.fastslam.resampling import (
    island_bounds,
    island_resample,
    multinomial_resample,
    normalize_per_island,
    stratified_resample,
    systematic_resample,
)

_RESAMPLERS = {
    ResamplingScheme.SYSTEMATIC: systematic_resample,
    ResamplingScheme.STRATIFIED: stratified_resample,
    ResamplingScheme.MULTINOMIAL: multinomial_resample,
}


class Resampler:
    """Resamples the particle set when its weights have degenerated.

    Args:
        config: the resampling section (scheme, ESS fraction).
        n_particles: P.
        islands: K independent islands (1: one filter).
        rng: the filter's random generator.

    Attributes:
        islands: (K + 1,) the islands' start indices (``resampling.island_bounds``), or None
            for one filter.
        count: resamplings so far.
    """

    def __init__(
        self, config: ResamplingConfig, n_particles: int, islands: int, rng: np.random.Generator
    ) -> None:
        self._fraction = config.ess_fraction
        self._resample = _RESAMPLERS[config.scheme]
        self._rng = rng
        self.islands = None if islands == 1 else island_bounds(n_particles, islands)
        self.count = 0

    def __call__(
        self, particles: ParticleSet, store: LandmarkStore, history: PathHistory, ess: float
    ) -> np.ndarray | None:
        """Resample ``particles`` and the maps in ``store`` if their effective sample size
        ``ess`` is low (every island on its own), recording the ancestors in ``history``.

        Returns:
            (P,) the ancestors, or None when nothing was resampled.
        """
        if self.islands is not None:
            ancestors = island_resample(
                particles.log_weights, self.islands, self._fraction, self._resample, self._rng
            )
        elif self._fraction >= 1.0 or ess < self._fraction * len(particles):
            # fraction 1 means "every step": ESS of equal weights is P only up to rounding
            ancestors = self._resample(particles.weights, self._rng)
        else:
            return None
        if ancestors is None:
            return None
        history.record_resampling(ancestors)
        particles.resample(ancestors)
        if self.islands is not None:
            particles.log_weights = normalize_per_island(particles.log_weights, self.islands)
        store.resample(ancestors)
        self.count += 1
        return ancestors
