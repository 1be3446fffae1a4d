"""Sequence -> ObservationLog: the shared front end, run once per sequence and configuration.

Every frame of the Sequence becomes one FrameInput with its odometry. Images are processed
asynchronously (thesis 4.5): only every k-th image, or the first image after d metres of
odometry (Barra & Costa process one every 37.5 cm), go through SIFT -> groups -> tracks;
the other frames carry odometry (and range-bearing sightings) only. Bearings are unit vectors
in the robot frame from the camera's viewpoint with the angular sigma of their pixel
(``CameraModel.angular_sigma``: larger towards the mirror rim, thesis eq. 4.23).

A sequence with a laser (``LaserRole.SENSOR``: not one kept for the occupancy grid only) and
no images gets laser odometry (``scan_matching``: each scan registered to the last few by ICP,
with a covariance; the wheel odometry where a match is rejected) as its frames' odometry
(``ObservationLog.odometry_source``, LASER); the laser landmarks are placed through it to keep
only those the previous scan saw there too (``laser_landmarks.persistent_sightings``), and the
tutorial's feet of the perpendicular, when asked for, are dropped through it.

Because the whole sequence is processed before any estimator runs, tracks with fewer than
``TrackConfig.min_track_length`` sightings (features seen once, unmatched) are dropped from the
log: no estimator can use them.
"""

from __future__ import annotations

import collections
import contextlib
import io
import itertools
import multiprocessing
import multiprocessing.forkserver
import os
import pickle
import signal
import sys
import threading
import time
import types
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from omnislam.core.se import se2_integrate
from omnislam.core.types import FrameInput, Odometry, OdometrySource, RangeBearing
from omnislam.errors import DataError
from omnislam.frontend import kernels_aot
from omnislam.frontend.config import FrontendConfig, ScheduleConfig, ScheduleMode, config_hash
from omnislam.frontend.config import config_to_dict as _config_to_dict
from omnislam.frontend.image_tracking import ImageTracking, TrackedImages
from omnislam.frontend.observation_log import (
    ObservationLog,
    StaleLogError,
    dataset_fingerprint,
    load_observation_log,
    save_observation_log,
)
from omnislam.frontend.preparation import (
    ImagePreparer,
    PreparedImage,
    prepare_in_worker,
    reuse_freed_memory,
    start_worker,
    worker_ready,
)
from omnislam.frontend.scale_space import use_kernels
from omnislam.frontend.timing import StageClock, children_cpu_s

if TYPE_CHECKING:
    from omnislam.datasets.sequence import Sequence
    from omnislam.frontend.scan_matching import LaserOdometry

#: default seed of the RANSAC generator when none is injected
DEFAULT_SEED = 0


def schedule_images(
    image_frames: np.ndarray, odometry_r: np.ndarray, config: ScheduleConfig
) -> np.ndarray:
    """The frames whose images are processed.

    Args:
        image_frames: (K,) frames that have an image, increasing.
        odometry_r: (N, 3) odometry of every frame (row i: motion from frame i-1 to i).
        config: every k-th image, or every d metres.

    Returns:
        (M,) the subset of ``image_frames`` to process.
    """
    image_frames = np.asarray(image_frames, dtype=np.int64)
    if image_frames.size == 0:
        return image_frames
    if config.mode is ScheduleMode.EVERY_K:
        return image_frames[:: config.every_k]
    travelled = np.concatenate([[0.0], np.cumsum(np.hypot(odometry_r[1:, 0],
                                                          odometry_r[1:, 1]))])
    chosen = [int(image_frames[0])]
    for frame in image_frames[1:]:
        if travelled[frame] - travelled[chosen[-1]] >= config.every_m:
            chosen.append(int(frame))
    return np.array(chosen, dtype=np.int64)


def log_key(config: FrontendConfig, max_images: int | None = None, seed: int = DEFAULT_SEED) -> str:
    """The configuration key of a log: ``config_hash``, suffixed when images were limited and
    when the RANSAC generator had another seed than ``DEFAULT_SEED`` (the seed changes the
    tracks, so ``omnislam frontend --resume`` must not keep a log of another seed)."""
    key = config_hash(config)
    if max_images is not None:
        key = f"{key}-first{max_images}"
    return key if seed == DEFAULT_SEED else f"{key}-seed{seed}"


def _sensing_laser(sequence: Sequence) -> bool:
    """The sequence has a laser the front end registers and extracts landmarks from (not one
    kept for the occupancy grid only, ``LaserRole.OCCUPANCY``)."""
    return sequence.laser is not None and sequence.laser.senses


def _has_own_sightings(sequence: Any) -> bool:
    """True when the loader gives range-bearing sightings in at least one frame."""
    own = sequence.range_bearing
    return own is not None and any(f is not None and len(f.landmark_ids) for f in own)


def _merge_sightings(a: RangeBearing | None, b: RangeBearing | None) -> RangeBearing | None:
    if a is None or b is None:
        return a if b is None else b
    return RangeBearing(
        np.concatenate([a.landmark_ids, b.landmark_ids]),
        np.concatenate([a.ranges_m, b.ranges_m]),
        np.concatenate([a.bearings_rad, b.bearings_rad]),
        np.concatenate([a.sigma_range_m, b.sigma_range_m]),
        np.concatenate([a.sigma_bearing_rad, b.sigma_bearing_rad]),
    )


#: processes preparing images when pipelined, and images prepared ahead of the one tracked
WORKERS = 2
LOOKAHEAD = 4


def _context(modules: list[str]) -> Any:
    """Workers forked from a fork server that has imported what they need once (Python's
    ``forkserver``): each starts in milliseconds where a spawned one re-imports numpy, scipy
    and OpenCV (~0.4 s of CPU each, ~10 % of the 59-image demo's run). Forking this process
    instead is not safe: its OpenCV and executor threads may hold locks (measured: a hang).
    Spawned where Python has no fork server, or no way to stop it (``_stop_fork_server``).

    The server imports ``preparation``, the compiled kernels, ``modules`` (those of the
    workers' arguments, ``_modules_of``) and the main module, which a worker would otherwise
    import again for itself (multiprocessing does that for the spawned and the fork server's
    processes); the tracking's modules (scipy's among them) it does not need.
    """
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    if ("forkserver" not in multiprocessing.get_all_start_methods()
            or not callable(getattr(server, "_stop", None))):
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(["__main__", "omnislam.frontend.preparation",
                                    "omnislam.frontend.kernels_compiled", *modules])
    return context


def _stop_fork_server(context: Any) -> None:
    """Stop the fork server and wait for it (Python's own ``ForkServer._stop``), so that its
    CPU and its reaped workers' count as this process's ended children, as spawned workers'
    do (every CPU figure of a run counts them that way), and no server outlives the run.

    Called once the workers have been joined (the server has reaped them, so their CPU is in
    its children's). The server is killed first: it holds no file or state to save, and
    exiting normally it would tear down numpy, OpenCV and numba (~0.2 s on the demo's run of
    3.4 s).
    """
    if context.get_start_method() != "forkserver":
        return
    server = multiprocessing.forkserver._forkserver
    pid = getattr(server, "_forkserver_pid", None)
    if pid is not None:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    server._stop()


class _ModuleRecorder(pickle.Pickler):
    """Pickles to nowhere, recording the module of every object and class it meets."""

    def __init__(self) -> None:
        super().__init__(io.BytesIO(), protocol=pickle.HIGHEST_PROTOCOL)
        self.modules: set[str] = set()

    def reducer_override(self, obj: Any) -> Any:
        # a class or function is pickled as a reference to its module; any other object
        # with its class
        by_reference = isinstance(obj, type | types.FunctionType)
        module = getattr(obj if by_reference else type(obj), "__module__", None)
        if isinstance(module, str):
            self.modules.add(module)
        return NotImplemented  # pickled as usual


def _modules_of(*objects: Any) -> list[str] | None:
    """The modules a process unpickling ``objects`` imports (sorted), or None when they
    cannot be pickled (so cannot be sent to a worker)."""
    recorder = _ModuleRecorder()
    try:
        recorder.dump(objects)
    except (pickle.PicklingError, AttributeError, TypeError):
        return None
    return sorted(m for m in recorder.modules if m not in ("builtins", "__main__"))


#: held by the run whose workers come from this process's fork server
_FORK_SERVER = threading.Lock()


class _WorkerPool:
    """The ``WORKERS`` processes, started in a background thread (``start``) so that this
    process can prepare the first images itself meanwhile: the fork server's start-up
    (importing ``preparation`` and loading its compiled kernels, ~0.6 s of CPU, most of it
    numba's) would otherwise leave a core idle before the first image."""

    def __init__(self, sequence: Any, config: FrontendConfig, modules: list[str]) -> None:
        # Python has one fork server per process, and a run stops it when it ends: a second
        # run at the same time in this process (threads of a Dask worker) spawns its workers
        self._owns_server = _FORK_SERVER.acquire(blocking=False)
        self.context = (_context(modules) if self._owns_server
                        else multiprocessing.get_context("spawn"))
        self.pool: ProcessPoolExecutor | None = None
        self.error: BaseException | None = None
        self.started_s = 0.0  # wall-clock seconds from ``start`` until the workers were up
        self._clock_start = 0.0
        self._args = (sequence.image_loader, sequence.calibration, config)
        self._thread = threading.Thread(target=self._start, name="omnislam-frontend-workers",
                                        daemon=True)

    def _start(self) -> None:
        try:
            self.pool = ProcessPoolExecutor(max_workers=WORKERS, mp_context=self.context,
                                            initializer=start_worker, initargs=self._args)
            # one task per worker makes the executor start them all now
            for future in [self.pool.submit(worker_ready) for _ in range(WORKERS)]:
                future.result()
            self.started_s = time.perf_counter() - self._clock_start
        except BaseException as exc:  # re-raised by ``wait`` in the caller's thread
            self.error = exc

    def start(self) -> None:
        self._clock_start = time.perf_counter()
        self._thread.start()

    def starting(self) -> bool:
        return self._thread.is_alive()

    def wait(self) -> ProcessPoolExecutor:
        self._thread.join()
        if self.error is not None:
            raise self.error
        assert self.pool is not None
        return self.pool

    def close(self) -> None:
        """Shut the workers down and stop their fork server (``_stop_fork_server``)."""
        if self._thread.ident is not None:  # started
            self._thread.join()
        try:
            if self.pool is not None:
                self.pool.shutdown(wait=True, cancel_futures=True)
        finally:
            if self._owns_server:
                try:
                    _stop_fork_server(self.context)
                finally:
                    _FORK_SERVER.release()


def _prepare_here(prepare: ImagePreparer, i: int) -> PreparedImage:
    """Image i prepared in this process while the workers start, with the compiled kernels
    when this process has loaded them already or they were compiled ahead of time (loaded in
    milliseconds, ``kernels_aot``), else on the numpy path (the same bits): compiling them with
    numba (~0.5 s) would cost more than they save on the few images prepared here. The switch
    is process-wide: a front end running meanwhile in another thread of this process takes the
    numpy path for those moments too, with the same bits."""
    if "omnislam.frontend.kernels_compiled" in sys.modules or kernels_aot.path().is_file():
        return prepare(i)
    previous = use_kernels(False)
    try:
        return prepare(i)
    finally:
        use_kernels(previous)


def _prepared(sequence: Any, config: FrontendConfig, frames: list[int], pipelined: bool,
              timing: dict[str, float] | None = None) -> Iterator[tuple[int, PreparedImage]]:
    """``(frame, prepared image)`` in order; ``timing`` receives ``seconds_workers_start``,
    the wall-clock seconds until the workers were up, when they were used.

    Pipelined, up to ``LOOKAHEAD`` images are prepared ahead in ``WORKERS`` processes while
    this one tracks (threads would not overlap: the preparation is mostly numpy calls that
    hold the GIL; docs/results/real-time.md). Until the workers have started, this process
    prepares the images itself (``_WorkerPool``). A sequence whose image loader cannot be sent
    to another process is prepared here, one image at a time.
    """
    rig = sequence.calibration
    modules = None
    if pipelined and not multiprocessing.current_process().daemon:  # may have children
        modules = _modules_of(sequence.image_loader, rig, config)
    if modules is None:  # one image at a time, here
        prepare = ImagePreparer(sequence.image_loader, rig, config)
        for i in frames:
            yield i, prepare(i)
        return
    workers = _WorkerPool(sequence, config, modules)
    try:
        workers.start()
        queue = iter(frames)
        local = None
        while workers.starting():
            i = next(queue, None)
            if i is None:
                break
            local = local if local is not None else ImagePreparer(sequence.image_loader,
                                                                  rig, config)
            yield i, _prepare_here(local, i)
        pool = workers.wait()
        if timing is not None:
            timing["seconds_workers_start"] = workers.started_s
        pending: collections.deque = collections.deque()
        for i in itertools.islice(queue, LOOKAHEAD):
            pending.append((i, pool.submit(prepare_in_worker, i)))
        while pending:
            i, future = pending.popleft()
            for j in itertools.islice(queue, 1):
                pending.append((j, pool.submit(prepare_in_worker, j)))
            yield i, future.result()
    finally:
        workers.close()


def run_frontend(
    sequence: Any,
    config: FrontendConfig | None = None,
    *,
    rng: np.random.Generator | None = None,
    max_images: int | None = None,
    progress: bool = False,
    pipelined: bool = False,
    on_image: Callable[[int, int], None] | None = None,
) -> ObservationLog:
    """Run the front end over a Sequence.

    Args:
        sequence: an ``omnislam.datasets.Sequence`` (its ``calibration`` must be a CameraRig
            when it has images).
        config: the configuration (default ``FrontendConfig()``: OMNI_THESIS SIFT).
        rng: generator for RANSAC (default: seeded with ``DEFAULT_SEED``).
        max_images: process at most this many images (the log still has every frame).
        progress: show the images done, rate and ETA on stderr (``omnislam._progress``).
        pipelined: prepare the next images (load, SIFT, vertical edges) in
            ``WORKERS`` processes while image k is tracked (the CLI does); the log is the same
            either way (a test). The processes are forked from a fork server started for the
            run (``_context``), which imports the main module as a spawned process would: a
            script calling this must guard its top level with ``if __name__ == "__main__":``,
            and what it imports at its top level every run's start-up imports too. The
            feature groups, rays and bearing sigmas are computed here, as each image arrives.
            This process and the workers keep freed memory for the next image
            (``reuse_freed_memory``).
        on_image: called with (images done, images to do) after each image (the grid runner's
            progress from a worker).

    Returns:
        The ObservationLog; ``stats`` holds counts, and wall-clock (``seconds_<stage>``) and
        CPU (``cpu_seconds_<stage>``) seconds per stage, and both for the whole image loop
        (``*_images_total``; its CPU counts the worker processes' whole CPU, start-up and
        pickling included, and their fork server's, as the children's resource usage once
        they have ended); pipelined, also the images prepared in the workers and their
        stages' CPU (``images_prepared_in_workers``, ``cpu_seconds_prepared_in_workers``) and
        the wall-clock seconds until the workers were up (``seconds_workers_start``; the
        images before were prepared here).
    """
    config = config if config is not None else FrontendConfig()
    rng = rng if rng is not None else np.random.default_rng(DEFAULT_SEED)
    reuse_freed_memory()
    return _FrontendRun(sequence, config, rng, max_images).run(
        progress=progress, pipelined=pipelined, on_image=on_image
    )


class _FrontendRun:
    """One run of the front end over a sequence (``run_frontend``): its stages in order, and
    the clocks and image-loop totals they report to the log's ``stats``.

    Args:
        sequence: the Sequence.
        config: the front-end configuration.
        rng: RANSAC's generator (the image tracking draws from it, then the laser landmarks).
        max_images: process at most this many images, or None.
    """

    def __init__(self, sequence: Any, config: FrontendConfig, rng: np.random.Generator,
                 max_images: int | None) -> None:
        self.sequence, self.config, self.rng, self.max_images = sequence, config, rng, max_images
        self.clock = StageClock()  # preparing images (in worker processes when pipelined), laser
        self.track_clock = StageClock()  # tracking the images (this thread)
        self.workers_timing: dict[str, float] = {}  # seconds_workers_start, when pipelined
        self.images_wall_s = 0.0  # the whole image loop
        self.images_cpu_s = 0.0

    def run(self, *, progress: bool, pipelined: bool,
            on_image: Callable[[int, int], None] | None) -> ObservationLog:
        """The log: the images tracked, the laser odometry and landmarks, one FrameInput per
        frame, and the stats."""
        images = self._images(progress, pipelined, on_image)
        laser_odom = self._laser_odometry()
        laser_sightings = self._laser_sightings(laser_odom)
        frames, pixels = self._frames(images, laser_odom, laser_sightings)
        return ObservationLog(
            dataset_id=dataset_fingerprint(self.sequence),
            config_hash=log_key(self.config, self.max_images),
            frames=tuple(frames),
            pixels=tuple(pixels),
            config=_config_to_dict(self.config),
            stats=self._stats(frames, images, laser_odom),
            odometry_source=OdometrySource.WHEEL if laser_odom is None else OdometrySource.LASER,
            floor_ids_from=images.floor_ids_from,
        )

    def _scheduled_images(self) -> np.ndarray:
        """The frames whose images are processed (``schedule_images``, at most ``max_images``).

        Raises:
            DataError: images to process and no camera calibration.
        """
        sequence = self.sequence
        if sequence.image_loader is None:
            return np.zeros(0, dtype=np.int64)
        processed = schedule_images(sequence.image_frames, sequence.odometry_r,
                                    self.config.schedule)
        if self.max_images is not None:
            processed = processed[: self.max_images]
        if processed.size and sequence.calibration is None:
            raise DataError(f"{sequence.name}: images without a camera calibration")
        return processed

    def _images(self, progress: bool, pipelined: bool,
                on_image: Callable[[int, int], None] | None) -> TrackedImages:
        """SIFT -> groups -> tracks on the scheduled images, the loop timed as a whole."""
        processed = self._scheduled_images()
        wall_start, cpu_start = time.perf_counter(), time.process_time()
        children_start = children_cpu_s()
        images = TrackedImages.none()
        if processed.size:
            images = self._track_images(processed.tolist(), progress, pipelined, on_image)
        self.images_wall_s = time.perf_counter() - wall_start
        # the workers and their fork server ended with the loop: their whole CPU (start-up,
        # pickling included) is known
        children_s = children_cpu_s() - children_start if children_start is not None else 0.0
        self.images_cpu_s = (time.process_time() - cpu_start
                             + max(images.prepared_cpu_s, children_s))
        return images

    def _track_images(self, frames: list[int], progress: bool, pipelined: bool,
                      on_image: Callable[[int, int], None] | None) -> TrackedImages:
        """Each image of ``frames`` prepared (``_prepared``) and tracked (``ImageTracking``)."""
        sequence = self.sequence
        tracking = ImageTracking(sequence.calibration, se2_integrate(sequence.odometry_r),
                                 self.config, self.rng, self.clock, self.track_clock)
        bar = None
        if progress:
            from omnislam._progress import Progress

            bar = Progress(f"frontend {sequence.name}", len(frames), "img")
        for i, image in _prepared(sequence, self.config, frames, pipelined,
                                  self.workers_timing):
            tracking.add(i, image)
            if bar is not None:
                bar.advance()
            if on_image is not None:
                on_image(len(tracking.sightings), len(frames))
        if bar is not None:
            bar.close()
        return tracking.finish()

    def _laser_odometry(self) -> LaserOdometry | None:
        """The laser odometry (``scan_matching``) when the sequence has a laser and the
        configuration asks for it (with images only when ``with_images``), else None."""
        sequence, config = self.sequence, self.config.laser_odometry
        if not _sensing_laser(sequence) or not config.enabled or not (
            config.with_images or sequence.image_loader is None
        ):
            return None
        from omnislam.frontend.mounted_laser import robot_laser_odometry

        with self.clock("laser_odometry"):  # the robot's motion, the scanner off its origin
            return robot_laser_odometry(sequence.laser, sequence.odometry_r, config,
                                        sequence.odometry_covariance_r)

    def _laser_sightings(self, laser_odom: LaserOdometry | None) -> dict[int, RangeBearing]:
        """Per frame with a scan, its laser landmarks (``laser_landmarks``), when the laser is
        on and the sequence has no sightings of its own or they are to be merged."""
        sequence, config = self.sequence, self.config.laser
        if not _sensing_laser(sequence) or not config.enabled or not (
            config.merge_with_sightings or not _has_own_sightings(sequence)
        ):
            return {}
        from omnislam.frontend.mounted_laser import robot_laser_landmarks

        scans = sequence.laser
        # the feet of the perpendicular are dropped from the odometry frame's origin through
        # the odometry the estimators get (the laser odometry when it is on)
        poses_dr = se2_integrate(
            sequence.odometry_r if laser_odom is None else laser_odom.deltas
        )
        sightings: dict[int, RangeBearing] = {}
        with self.clock("laser"):
            for i in range(len(sequence)):
                if np.all(np.isnan(scans.ranges_m[i])):
                    continue
                sightings[i] = robot_laser_landmarks(scans, i, config, self.rng, poses_dr[i])
            if config.persistence_radius_m is not None:
                from omnislam.frontend.laser_landmarks import persistent_sightings

                sightings = persistent_sightings(sightings, poses_dr,
                                                 config.persistence_radius_m,
                                                 config.persistence_scans)
        return sightings

    def _frames(self, images: TrackedImages, laser_odom: LaserOdometry | None,
                laser_sightings: dict[int, RangeBearing]
                ) -> tuple[list[FrameInput], list[np.ndarray | None]]:
        """One FrameInput per frame and the pixels of its bearings: the bearings of the kept
        tracks, the sequence's range-bearing sightings then the laser landmarks, the vertical
        lines, and the laser odometry (with its covariance) when there is one."""
        sequence = self.sequence
        keep_track = images.track_sightings >= self.config.tracks.min_track_length
        frames: list[FrameInput] = []
        pixels: list[np.ndarray | None] = []
        for i in range(len(sequence)):
            bearings, px = None, None
            if i in images.sightings:
                bearings, px = images.sightings[i].bearings(keep_track)
            given = sequence.range_bearing[i] if sequence.range_bearing is not None else None
            frame = sequence.frame_input(
                i,
                bearings=bearings,
                range_bearing=_merge_sightings(given, laser_sightings.get(i)),
                vertical_lines=images.lines.get(i),
            )
            if laser_odom is not None and i > 0:
                cov = laser_odom.covariances[i]
                frame = replace(frame, odometry=Odometry(
                    laser_odom.deltas[i], frame.odometry.stamp_s,
                    None if np.any(np.isnan(cov)) else cov,
                ))
            frames.append(frame)
            pixels.append(px)
        return frames, pixels

    def _stats(self, frames: list[FrameInput], images: TrackedImages,
               laser_odom: LaserOdometry | None) -> dict[str, float]:
        """The log's ``stats``: seconds per stage, the image loop's totals, and counts."""
        keep_track = images.track_sightings >= self.config.tracks.min_track_length
        n_bearings = [len(f.bearings) for f in frames if f.bearings is not None]
        stats: dict[str, float] = {}
        for c in (self.clock, self.track_clock):
            stats |= {f"seconds_{k}": v for k, v in c.seconds.items()}
            stats |= {f"cpu_seconds_{k}": v for k, v in c.cpu_seconds.items()}
        stats |= {
            "seconds_images_total": self.images_wall_s,
            "cpu_seconds_images_total": self.images_cpu_s,
            "images_processed": float(len(images.sightings)),
            "images_prepared_in_workers": float(images.prepared_in_workers),
            **self.workers_timing,
            "cpu_seconds_prepared_in_workers": images.prepared_cpu_s,
            "tracks_total": float(images.track_sightings.shape[0]),
            "tracks_kept": float(keep_track.sum()),
            "matches_beyond_floor": float(images.beyond_floor),
            "sightings_per_image_median": float(np.median(n_bearings)) if n_bearings else 0.0,
        }
        if images.floor_ids_from is not None:
            stats["floor_tracks_kept"] = float(keep_track[images.floor_ids_from :].sum())
        if laser_odom is not None:
            matched = [r for r in laser_odom.reasons if r]
            stats["laser_odometry_matches"] = float(len(matched))
            stats["laser_odometry_accepted"] = float(laser_odom.accepted.sum())
        return stats


def cached_frontend(
    sequence: Any,
    path: str | Path,
    config: FrontendConfig | None = None,
    *,
    rng: np.random.Generator | None = None,
    progress: bool = False,
    pipelined: bool = False,
    on_image: Callable[[int, int], None] | None = None,
) -> ObservationLog:
    """Load the log at ``path`` if it was built from this sequence and configuration, else
    run the front end (``run_frontend``, ``pipelined`` or not, ``on_image`` called after each
    image) and write it there.
    """
    config = config if config is not None else FrontendConfig()
    path = Path(path)
    if path.exists():
        try:
            return load_observation_log(path, dataset_id=dataset_fingerprint(sequence),
                                        config_hash=log_key(config))
        except StaleLogError:
            pass
    log = run_frontend(
        sequence, config, rng=rng, progress=progress, pipelined=pipelined, on_image=on_image
    )
    save_observation_log(log, path)
    return log
