"""The SIFT detector's compiled kernels give the numpy / OpenCV reference's bits.

The front end's log must not depend on whether numba is installed (``frontend/kernels.py``):
the candidates are compared exactly (the kernels only compare float32 values), and the
refinement's float64 arithmetic is written out in the reference's order, so its offsets and
contrasts are compared exactly too, as are the detections and descriptors of whole images.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from omnislam.frontend import scale_space
from omnislam.frontend.config import OMNI_THESIS
from omnislam.frontend.scale_space import IMAGE_BORDER, build_scale_space
from omnislam.frontend.sift import SiftExtractor, detection_mask

cv2 = pytest.importorskip("cv2")
pytest.importorskip("numba")

from omnislam.frontend import kernels_aot, kernels_compiled  # noqa: E402 (numba is installed)


@pytest.fixture(scope="module")
def jit_kernels():
    """numba's just-in-time kernels (what runs when none were compiled ahead of time)."""
    return kernels_compiled._compile()


@pytest.fixture(scope="module")
def aot_kernels(tmp_path_factory):
    """The kernels compiled ahead of time (``kernels_aot``): the installed build when it
    matches this source and machine (``make kernels``, what runs), else a fresh build
    (~10 s)."""
    module = kernels_aot.load()
    if module is None:
        folder = tmp_path_factory.mktemp("aot")
        try:
            kernels_aot.build(folder)
        except Exception as exc:  # no C compiler: numba's just-in-time path is what runs
            pytest.skip(f"cannot compile ahead of time here: {type(exc).__name__}: {exc}")
        module = kernels_aot.load(folder)
    assert module is not None
    return SimpleNamespace(**{name: getattr(module, name) for name in kernels_aot.SIGNATURES})


@pytest.fixture(params=["jit", "aot"])
def compiled(request, monkeypatch):
    """Each test runs with both compilations of the kernels as ``kernels_compiled.COMPILED``."""
    namespace = request.getfixturevalue(f"{request.param}_kernels")
    monkeypatch.setattr(kernels_compiled, "COMPILED", namespace)
    return namespace


@pytest.fixture
def reference():
    """Run the body on the numpy / OpenCV path (``scale_space.use_kernels(False)``)."""

    class _Switch:
        def __enter__(self):
            self.previous = scale_space.use_kernels(False)

        def __exit__(self, *exc):
            scale_space.use_kernels(self.previous)

    return _Switch()


def _textured(seed: int, size: int = 160) -> np.ndarray:
    """A grey image of blobs and edges at several scales, with noise (uint8)."""
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:size, 0:size].astype(float)
    image = 120.0 + 10.0 * rng.standard_normal((size, size))
    for _ in range(40):
        cu, cv_, s = rng.uniform(0, size), rng.uniform(0, size), rng.uniform(1.0, 8.0)
        image += rng.choice([-1, 1]) * 60.0 * np.exp(-((u - cu) ** 2 + (v - cv_) ** 2) / (2 * s**2))
    image[:, size // 3] += 40.0  # an edge: rejected by the curvature test
    return np.clip(np.round(image), 0, 255).astype(np.uint8)


def _omni(demo_sequence, frame: int) -> tuple[np.ndarray, np.ndarray]:
    camera = demo_sequence.calibration.camera
    image = demo_sequence.image(frame)
    return image, detection_mask(camera.mask(), (camera.height, camera.width))


def _inner(shape: tuple[int, int], mask: np.ndarray | None) -> np.ndarray:
    inner = np.zeros(shape, dtype=np.uint8)
    b = IMAGE_BORDER
    inner[b:-b, b:-b] = 255
    return inner if mask is None else cv2.bitwise_and(inner, mask)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_extrema_are_the_references_in_its_order(seed, reference, compiled):
    grey = _textured(seed)
    mask = np.zeros(grey.shape, dtype=np.uint8)
    mask[20:140, 10:150] = 255
    total = 0
    for octave in build_scale_space(grey, 1.6, 3, fine=True):
        span, step = octave.extrema_layers, octave.step_px
        height, width = octave.dog.shape[1:]
        octave_mask = np.ascontiguousarray(mask[::step, ::step][:height, :width])
        for threshold in (0.0, 0.005, 0.01):
            with reference:
                expected = scale_space._candidates(octave.dog, span, threshold, octave_mask)
            found = compiled.extrema(
                octave.dog, span, np.float32(threshold), _inner((height, width), octave_mask)
            )
            for want, got in zip(expected, found.T, strict=True):
                np.testing.assert_array_equal(got, want)
            total += found.shape[0]
    assert total > 50  # the comparison saw real extrema


def test_the_extrema_grow_their_buffer_past_its_first_size(compiled):
    """More than the kernel's first 1024 extrema: a checkerboard of isolated peaks."""
    dog = np.zeros((3, 200, 200), dtype=np.float32)
    dog[1, 6:194:3, 6:194:3] = 1.0
    found = compiled.extrema(dog, 1, np.float32(0.5), _inner((200, 200), None))
    assert found.shape[0] == len(range(6, 194, 3)) ** 2 > 1024
    np.testing.assert_array_equal(found[:, 0], 1)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_refinement_gives_the_references_bits(seed, reference, compiled):
    grey = _textured(seed)
    kept = 0
    for octave in build_scale_space(grey, 1.6, 3, fine=True):
        span = octave.extrema_layers
        with reference:
            s, r, c = scale_space._candidates(octave.dog, span, 0.005, None)

        def refine(dog=octave.dog, span=span, s=s, r=r, c=c):
            # the Newton steps move the candidates in place: each call gets its own copies
            return scale_space._refine(dog, span, s.copy(), r.copy(), c.copy(),
                                       OMNI_THESIS.contrast_threshold,
                                       OMNI_THESIS.edge_threshold)

        with reference:
            want = refine()
        got = refine()
        for field in ("layer", "row", "col", "offset", "contrast"):
            np.testing.assert_array_equal(getattr(got, field), getattr(want, field))
        kept += got.layer.size
    assert kept > 10


def test_whole_omni_images_give_the_same_features(demo_sequence, reference, compiled):
    """The features of rendered omni images (the front end's input), every field exact."""
    extractor = SiftExtractor(OMNI_THESIS)
    for frame in demo_sequence.image_frames[:3]:
        image, mask = _omni(demo_sequence, int(frame))
        with reference:
            want = extractor.extract(image, mask)
        got = extractor.extract(image, mask)
        assert len(got) > 100
        for field in ("pixels", "sizes_px", "angles_rad", "contrast", "descriptors"):
            np.testing.assert_array_equal(getattr(got, field), getattr(want, field))


@pytest.mark.parametrize("seed", [0, 1])
def test_the_orientations_are_the_references(seed, reference, compiled):
    """Keypoints near the border too (their windows are clipped): the same orientations."""
    grey = _textured(seed)
    octave = build_scale_space(grey, 1.6, 3, fine=True)[0]
    height, width = octave.gaussian.shape[1:]
    rng = np.random.default_rng(seed)
    m = 60
    layer = rng.integers(1, octave.extrema_layers + 1, m)
    rows = np.concatenate([rng.integers(1, height - 1, m - 4), [1, 2, height - 2, height - 3]])
    cols = np.concatenate([rng.integers(1, width - 1, m - 4), [width - 2, 1, 3, width - 3]])
    scales = rng.uniform(0.8, 4.0, m)
    with reference:
        want = scale_space._orientations(octave.gaussian, layer, rows, cols, scales)
    got = scale_space._orientations(octave.gaussian, layer, rows, cols, scales)
    assert want[0].size >= m
    for a, b in zip(got, want, strict=True):
        np.testing.assert_array_equal(a, b)


def test_the_ahead_of_time_module_is_named_by_what_its_code_depends_on(tmp_path, monkeypatch):
    """Another kernels source (or Python, numpy, CPU) is another file: a module built for
    other kernels is never loaded; none built: None (numba's just-in-time path runs)."""
    assert kernels_aot.load(tmp_path) is None
    before = kernels_aot.path(tmp_path)
    assert before.parent == tmp_path and kernels_aot.key() in before.name
    edited = tmp_path / "kernels.py"
    edited.write_text(kernels_aot._SOURCE.read_text() + "\n# edited\n")
    kernels_aot.key.cache_clear()
    monkeypatch.setattr(kernels_aot, "_SOURCE", edited)
    try:
        assert kernels_aot.path(tmp_path) != before
    finally:
        monkeypatch.undo()
        kernels_aot.key.cache_clear()
    assert kernels_aot.path(tmp_path) == before


def test_a_module_that_cannot_be_loaded_leaves_the_just_in_time_path(tmp_path):
    """A damaged file under this key (not a module) is a warning and None, not a crash."""
    kernels_aot.path(tmp_path).write_bytes(b"not a shared object")
    with pytest.warns(RuntimeWarning, match="cannot load"):
        assert kernels_aot.load(tmp_path) is None
