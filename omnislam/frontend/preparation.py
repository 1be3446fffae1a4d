"""One image's preparation for tracking, independent of every other image: load, SIFT, vertical
edges; and the worker processes that do it ahead of the tracker when the front end is pipelined.

This module is what a worker imports (``pipeline``'s fork server preloads it with the compiled
kernels), so it imports only what preparing an image needs: numpy, OpenCV, the detector and the
camera. What needs the rest of the front end (the feature groups use scipy's k-d tree and graph
components, ~0.2 s to import) is done by the tracking process, on the features it receives
(``pipeline``). A worker that imported the whole front end would spend that time before its
first image on every run.
"""

from __future__ import annotations

import ctypes
import dataclasses
from dataclasses import dataclass
from typing import Any

from omnislam._optional import require
from omnislam.frontend.config import FrontendConfig
from omnislam.frontend.sift import SiftExtractor, detection_mask
from omnislam.frontend.timing import StageClock


@dataclass(frozen=True, slots=True)
class PreparedImage:
    """What the tracker needs of one image that no other image changes.

    Attributes:
        features: its SIFT features.
        lines: its vertical lines, or None when they are not extracted.
        seconds: wall-clock seconds per stage spent preparing it.
        cpu_seconds: CPU seconds per stage (of the process that prepared it).
        in_worker: prepared in a worker process (whose CPU this process does not count).
    """

    features: Any
    lines: Any
    seconds: dict[str, float]
    cpu_seconds: dict[str, float]
    in_worker: bool = False


class ImagePreparer:
    """Load, SIFT and vertical edges of one image (no state between images).

    Args:
        image_loader: ``image_loader(i)`` -> (H, W, 3) uint8 image of frame i.
        rig: the camera rig.
        config: the front-end configuration.
    """

    def __init__(self, image_loader: Any, rig: Any, config: FrontendConfig) -> None:
        camera = rig.camera
        self.image_loader, self.config, self.rig = image_loader, config, rig
        self.mask = detection_mask(camera.mask(), (camera.height, camera.width))
        self.extractor = SiftExtractor(config.sift)
        self.vertical = None
        if config.vertical_edges.enabled:
            from omnislam.frontend.vertical_edges import VerticalLineExtractor

            self.vertical = VerticalLineExtractor(rig, config.vertical_edges)

    def __call__(self, i: int) -> PreparedImage:
        clock = StageClock()
        with clock("load"):
            image = self.image_loader(i)
        with clock("extract"):
            features = self.extractor.extract(image, self.mask)
        lines = None
        if self.vertical is not None:
            with clock("vertical_edges"):
                lines = self.vertical.extract(image)
        return PreparedImage(features, lines, clock.seconds, clock.cpu_seconds)


#: glibc's mallopt parameters, and the values ``reuse_freed_memory`` sets
_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3
_MMAP_THRESHOLD_B = 32 << 20  # glibc's largest (half its heap size)
_TRIM_THRESHOLD_B = 512 << 20
_TOP_PAD_B = 64 << 20


def reuse_freed_memory() -> bool:
    """Make this process's allocator keep freed memory for the next image (glibc only).

    Every image allocates the same large arrays (the scale space: ~28 MB of float32 images,
    OpenCV's descriptor pyramid, the tracker's distance matrices). By default glibc serves
    blocks this large with fresh ``mmap`` pages and returns them on ``free``, so every image
    pays ~4000 page faults (zero-filling its pages): ~8 ms of CPU per lab40 image, 15 % of
    SIFT's. Serving them from a heap that is not trimmed reuses the same pages. A process-wide
    setting; harmless elsewhere (freed memory stays with the process, up to 512 MB).

    Returns:
        True when it was set (False on a platform without glibc).
    """
    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):
        return False
    return all(mallopt(option, value) == 1 for option, value in (
        (_M_MMAP_THRESHOLD, _MMAP_THRESHOLD_B), (_M_TRIM_THRESHOLD, _TRIM_THRESHOLD_B),
        (_M_TOP_PAD, _TOP_PAD_B)))


#: the preparer of a worker process (built once by ``start_worker``)
_WORKER: ImagePreparer | None = None


def start_worker(image_loader: Any, rig: Any, config: FrontendConfig) -> None:
    """A worker process's initializer: its preparer, OpenCV on one thread (the processes
    share the cores, not OpenCV's threads), freed memory kept."""
    global _WORKER
    require("cv2").setNumThreads(1)
    reuse_freed_memory()
    _WORKER = ImagePreparer(image_loader, rig, config)


def prepare_in_worker(i: int) -> PreparedImage:
    """Image i prepared by this worker's preparer."""
    assert _WORKER is not None
    return dataclasses.replace(_WORKER(i), in_worker=True)


def worker_ready() -> bool:
    """A task that returns once a worker process has started (its initializer has run)."""
    return _WORKER is not None
