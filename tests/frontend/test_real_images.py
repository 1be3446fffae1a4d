"""Smoke test on real catadioptric images: the OCamCalib VMR lab samples.

The hand-held camera mostly turns about its mirror axis between shots (the checkerboard is
the only thing that moves in the scene), and there is no odometry. Verification therefore
runs with a "no translation, any rotation" prior (the pure-rotation model) and with no prior
at all (the essential matrix). The images come without their calibration: an approximate
unified model centred on the mirror serves, since a turn about the axis is an image rotation
about that centre whatever the radial profile.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from omnislam.frontend.config import OMNI_THESIS, MatchConfig, VerificationConfig
from omnislam.frontend.matching import match_brute_force
from omnislam.frontend.sift import SiftExtractor
from omnislam.frontend.verification import ModelKind, RelativePose, verify_matches

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
VMR = DATA / "omni_real" / "vmr_lab_ocamcalib_samples"
#: minimum verified matches per image pair (measured: 57-251 over the nine pairs)
MIN_VERIFIED = 50
#: inlier threshold for an uncalibrated (approximate) model [rad]
THRESHOLD_RAD = 0.01
#: image pairs checked (the first ones; all nine in benchmarks/frontend.py)
PAIRS = 3


def verified_matches_per_pair(pairs: int | None = PAIRS) -> list[tuple[int, int, int]]:
    """``(ratio-test matches, verified essential, verified rotation-only)`` per image pair."""
    cv2 = pytest.importorskip("cv2")
    from omnislam.camera.unified import UnifiedCamera

    if not VMR.is_dir():
        pytest.skip(f"real omni images not found at {VMR}")
    paths = sorted(VMR.glob("VMRImage*.jpg"))
    paths = paths if pairs is None else paths[: pairs + 1]
    images = [cv2.cvtColor(cv2.imread(str(p)), cv2.COLOR_BGR2RGB) for p in paths]
    h, w = images[0].shape[:2]
    camera = UnifiedCamera(xi=1.0, gamma1=0.4 * w, gamma2=0.4 * w, cu=(w - 1) / 2,
                           cv=(h - 1) / 2, width=w, height=h)
    extractor = SiftExtractor(OMNI_THESIS)
    features = [extractor.extract(image) for image in images]
    rng = np.random.default_rng(0)
    any_turn = VerificationConfig(threshold_rad=THRESHOLD_RAD, prior_rotation_tol_rad=np.pi,
                                  planar_motion=False)
    out = []
    for a, b in itertools.pairwise(features):
        m = match_brute_force(b.descriptors, a.descriptors, MatchConfig())
        f1 = camera.unproject(a.pixels[m.train])
        f2 = camera.unproject(b.pixels[m.query])
        # hand-held: the general (8-point) model, not the wheeled robot's planar one
        general = VerificationConfig(threshold_rad=THRESHOLD_RAD, planar_motion=False)
        essential = verify_matches(f1, f2, None, general, rng)
        turn = verify_matches(f1, f2, RelativePose(np.eye(3), np.zeros(3)), any_turn, rng)
        assert essential.kind is ModelKind.ESSENTIAL and turn.kind is ModelKind.ROTATION
        out.append((len(m), essential.n_inliers, turn.n_inliers))
    return out


def test_verified_matches_between_real_lab_images():
    for n_matches, essential, turn in verified_matches_per_pair():
        assert MIN_VERIFIED <= essential <= n_matches
        assert 0 < turn <= n_matches
