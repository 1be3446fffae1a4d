"""Write a synthetic run to disk, atomically and byte-reproducibly.

On-disk format of a synthetic folder (``omnislam dataset synth PRESET --out DIR``)
-------------------------------------------------------------------------------
All files are written into a temporary sibling folder that is renamed to ``DIR`` at the end,
so a crash leaves no half-written dataset. The same preset, seed, frame limit and backend give
byte-identical files (no time stamps anywhere; zip entries carry a fixed date).

``meta.json``
    ``{"format": "omnislam-synthetic", "version": 1, "preset", "seed", "backend", "frames",
    "images", "image_every_k", "description", "source", "odometry_bias", "motion_noise"}``
    (``image_every_k``: one image every that many frames, the preset's unless ``omnislam dataset
    synth --image-every`` chose another; the last two: the simulated robot's systematic odometry
    errors and alpha coefficients, as dicts). Optional, present only where a preset sets them:
    ``"pole_scanner"`` (the laser whose scan's local minima are the pole sightings, as a dict),
    ``"association": "unknown"`` (the loader hides the sightings' ids unless told otherwise)
    and ``"laser_role": "occupancy"`` (``laser.npz`` is for the occupancy grid only). Present
    only for a render that is not clean (``--realism``): ``"realism"`` (``realism.Realism``
    value; absent = ``"clean"``).
``world.json``
    The world: quads (surface id = index), texture specs, poles, vertical lines, 2-D walls.
``calibration.yaml``
    The camera rig (``omnislam.camera.io.save_rig``): camera model + ``rTc``. Absent for
    laser-only runs.
``groundtruth.tum``
    True pose of every frame (10 Hz), TUM format ``stamp x y z qx qy qz qw``, z = 0.
``odometry.csv``
    ``stamp_s,dx_m,dy_m,dtheta_rad,true_dx_m,true_dy_m,true_dtheta_rad``: one row per frame;
    the robot-frame motion since the previous frame, measured (the robot's systematic bias,
    ``routes.OdometryBias``, then the thesis alpha model, eqs. 4.38-4.44) and true. Row 0 is
    zero.
``images/NNNNNN.png``
    RGB images (8 bit) of the frames that have one; NNNNNN = frame index (zero-padded). With
    ``realism`` other than clean, the camera sensor model's output (``sensor.CameraSensor``:
    blur, vignetting, noise, exposure, JPEG round trip) stored losslessly.
``exposures.csv``
    ``frame,exposure_s,gain``: the auto-exposure's choice for every image; only with a camera
    sensor (``realism`` other than clean).
``gt/NNNNNN.npz``
    Per-image ground truth: ``surface_id`` (H, W) int32, the surface seen by each pixel
    centre (-1 outside the mask or no hit). The world point of a pixel is exact and not
    stored twice: it is the intersection of the pixel's ray (``calibration.yaml``, pose in
    ``groundtruth.tum``) with the plane of quad ``surface_id`` (``world.json``);
    ``loader.read_ground_truth_maps`` returns it as ``points_w`` (H, W, 3) float32.
``laser.npz``
    ``angles_rad`` (B,), ``ranges_m`` (N, B) (``max_range_m`` = no return), ``max_range_m``.
``poles.csv``
    ``frame,landmark_id,range_m,bearing_rad,sigma_range_m,sigma_bearing_rad``: noisy pole
    sightings with true ids (the thesis's laser stand-in for the camera, ch. 5.1.1), of the
    preset's pole scanner when it has one (the thesis's upper laser: ``laser.npz`` then holds
    the lower one's scans).
``landmarks.csv``
    ``id,x,y,z`` ground-truth 2-D landmarks (pole centres, door-frame vertical lines), z = 0.
``walls.csv``
    ``x0,y0,x1,y1`` main walls of the 2-D map (Barra & Costa's occlusion map).
``line_colours.csv``
    ``id,count,r_left,g_left,b_left,r_right,g_right,b_right``: the MC (Barra & Costa sec. 2.2)
    of every vertical-line landmark, surveyed in the rendered images at the true poses
    (``line_survey``), ``count`` images; empty colours where never seen. Only with images and
    vertical lines.
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._files import check_output_location, output_error
from omnislam.core.types import Trajectory
from omnislam.datasets._common import Association
from omnislam.datasets.sequence import LaserRole
from omnislam.datasets.synthetic.line_survey import LineSurvey
from omnislam.datasets.synthetic.raycast import Backend
from omnislam.datasets.synthetic.realism import Realism, realism_config
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.sensor import CameraSensor
from omnislam.datasets.synthetic.simulate import Simulation
from omnislam.errors import DataError

FORMAT_NAME = "omnislam-synthetic"
FORMAT_VERSION = 1
_ZIP_DATE = (1980, 1, 1, 0, 0, 0)
_FLOAT = "%.17g"


def frame_name(index: int) -> str:
    """File stem of frame ``index`` (``000042``)."""
    return f"{index:06d}"


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """``np.savez_compressed`` with fixed zip dates, so equal arrays give equal bytes."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name in sorted(arrays):
            buffer = io.BytesIO()
            np.lib.format.write_array(buffer, np.require(arrays[name], requirements="C"),
                                      allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_DATE)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            archive.writestr(info, buffer.getvalue(), compresslevel=6)


def _write_csv(path: Path, header: str, rows: np.ndarray, formats: list[str]) -> None:
    lines = [header]
    lines += [",".join(f % v for f, v in zip(formats, row, strict=True)) for row in rows]
    path.write_text("\n".join(lines) + "\n")


def prepare_output(out: Path, overwrite: bool) -> None:
    """Refuse a non-empty existing ``out`` unless ``overwrite`` (checked before any work)."""
    if out.exists():
        if not out.is_dir():
            raise DataError("exists and is not a folder", out)
        if any(out.iterdir()) and not overwrite:
            raise DataError("folder exists and is not empty (pass overwrite to replace it)", out)
    check_output_location(out, "synthetic folder")


def write_synthetic(
    out: str | Path,
    sim: Simulation,
    backend: Backend | str | None = None,
    supersample: int = 1,
    overwrite: bool = False,
    progress: Callable[[int], None] | None = None,
    realism: Realism | str = Realism.CLEAN,
) -> Path:
    """Render the images of ``sim`` and write the whole folder (format in the module docstring).

    Args:
        out: destination folder; must not exist or be empty unless ``overwrite``.
        sim: the simulated run.
        backend: ray caster for the images.
        supersample: 1 or 2 colour rays per pixel side.
        overwrite: replace a non-empty ``out``.
        progress: called with the number of images written so far.
        realism: CLEAN writes the renderer's images; REALISTIC passes them through the camera
            sensor model (``realism.realism_config``).

    Returns:
        The folder written.

    Raises:
        ConfigError: an unknown realism.
    """
    cv2 = _cv2()
    out = Path(out)
    realism = Realism.parse(realism)
    prepare_output(out, overwrite)
    backend = Backend.default() if backend is None else Backend(backend)
    tmp = _partial_folder(out)
    try:
        _write_meta(tmp, sim, backend, supersample, realism)
        _write_tables(tmp, sim)
        if sim.rig is not None and sim.image_frames.size:
            _write_images(tmp, sim, backend, supersample, cv2, progress, realism)
        _move_into_place(tmp, out)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise output_error(exc, out, "synthetic folder") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def _partial_folder(out: Path) -> Path:
    """A new empty ``.NAME.partial-PID`` folder beside ``out`` to write into (the stale ones
    of killed writers removed first)."""
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        _remove_stale_partials(out)
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir()
    except OSError as exc:
        raise output_error(exc, out, "synthetic folder") from None
    return tmp


def _move_into_place(tmp: Path, out: Path) -> None:
    """Rename the written ``tmp`` folder to ``out``, removing the folder it replaces."""
    if out.exists():
        trash = out.parent / f".{out.name}.old-{os.getpid()}"
        out.rename(trash)
        shutil.rmtree(trash)
    tmp.rename(out)


def _write_meta(folder: Path, sim: Simulation, backend: Backend, supersample: int,
                realism: Realism) -> None:
    """``meta.json``: the run's preset, seed, renderer and counts; the realism unless clean."""
    meta = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "preset": sim.preset.name,
        "seed": sim.seed,
        "backend": backend.value,
        "supersample": supersample,
        "frames": sim.stamps_s.shape[0],
        "images": int(sim.image_frames.size),
        "image_every_k": int(sim.preset.image_every_k),
        "description": sim.preset.description,
        "source": sim.preset.source,
        "odometry_bias": dataclasses.asdict(sim.preset.odometry_bias),
        "motion_noise": dataclasses.asdict(sim.preset.motion_noise),
    }
    meta.update(_loader_defaults(sim))
    if realism is not Realism.CLEAN:
        meta["realism"] = realism.value
    (folder / "meta.json").write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")


def _write_tables(folder: Path, sim: Simulation) -> None:
    """Everything but the images: ``world.json``, ``groundtruth.tum``, ``odometry.csv``,
    ``poles.csv``, ``landmarks.csv``, ``walls.csv`` and ``laser.npz``."""
    from omnislam.datasets.trajectory_io import write_tum

    (folder / "world.json").write_text(sim.world.to_json() + "\n")
    write_tum(folder / "groundtruth.tum", Trajectory.from_se2(sim.stamps_s, sim.poses_w))
    _write_csv(
        folder / "odometry.csv",
        "stamp_s,dx_m,dy_m,dtheta_rad,true_dx_m,true_dy_m,true_dtheta_rad",
        np.column_stack([sim.stamps_s, sim.odometry_r, sim.odometry_true_r]),
        [_FLOAT] * 7,
    )
    rows = [
        (i, lid, r, b, sr, sb)
        for i, rb in enumerate(sim.poles)
        for lid, r, b, sr, sb in zip(rb.landmark_ids, rb.ranges_m, rb.bearings_rad,
                                     rb.sigma_range_m, rb.sigma_bearing_rad, strict=True)
    ]
    _write_csv(folder / "poles.csv",
               "frame,landmark_id,range_m,bearing_rad,sigma_range_m,sigma_bearing_rad",
               np.array(rows, dtype=object).reshape(-1, 6), ["%d", "%d"] + [_FLOAT] * 4)
    ids, xyz = sim.world.landmarks()
    _write_csv(folder / "landmarks.csv", "id,x,y,z",
               np.column_stack([ids.astype(object), xyz]).reshape(-1, 4),
               ["%d", _FLOAT, _FLOAT, _FLOAT])
    walls = np.array([[w.x0_m, w.y0_m, w.x1_m, w.y1_m] for w in sim.world.walls_2d])
    _write_csv(folder / "walls.csv", "x0,y0,x1,y1", walls.reshape(-1, 4), [_FLOAT] * 4)
    write_npz(folder / "laser.npz", {
        "angles_rad": sim.preset.laser.angles_rad(),
        "ranges_m": sim.laser_ranges_m,
        "max_range_m": np.array(sim.preset.laser.max_range_m),
    })


def _write_images(folder: Path, sim: Simulation, backend: Backend, supersample: int, cv2: Any,
                  progress: Callable[[int], None] | None, realism: Realism) -> None:
    """``calibration.yaml``, the rendered ``images/`` and their ``gt/`` surface ids, the
    vertical lines' colours surveyed in them (``line_colours.csv``, in the clean images: the
    colours of the surfaces themselves) and, with a camera sensor, ``exposures.csv``."""
    from omnislam.camera.io import save_rig

    save_rig(sim.rig, folder / "calibration.yaml")
    (folder / "images").mkdir()
    (folder / "gt").mkdir()
    renderer = Renderer(sim.world, sim.rig, backend, supersample)
    lines = sim.world.vertical_lines
    survey = LineSurvey(
        np.array([v.landmark_id for v in lines], dtype=np.int64),
        np.array([(v.x_m, v.y_m) for v in lines]),
        sim.rig,
    )
    sensor_config = realism_config(realism).sensor
    sensor = (None if sensor_config is None
              else CameraSensor(sensor_config, sim.rig, sim.stamps_s, sim.poses_w, sim.seed))
    poses_se3 = Trajectory.from_se2(sim.stamps_s, sim.poses_w).poses_w
    for count, index in enumerate(sim.image_frames, start=1):
        frame = renderer.render(sim.poses_w[index])
        survey.add(frame.image, frame.points_w, poses_se3[index])
        name = frame_name(int(index))
        image = (frame.image if sensor is None
                 else sensor.capture(frame.image, frame.points_w, int(index)))
        if not cv2.imwrite(str(folder / "images" / f"{name}.png"), image[..., ::-1]):
            raise DataError("cannot write image", folder / "images" / f"{name}.png")
        write_npz(folder / "gt" / f"{name}.npz", {"surface_id": frame.surface_ids})
        if progress is not None:
            progress(count)
    if lines:
        _write_csv(
            folder / "line_colours.csv",
            "id,count,r_left,g_left,b_left,r_right,g_right,b_right",
            survey.rows().astype(object),
            ["%d", "%d"] + [_FLOAT] * 6,
        )
    if sensor is not None:
        _write_csv(folder / "exposures.csv", "frame,exposure_s,gain",
                   np.column_stack([sim.image_frames.astype(object),
                                    [(e.time_s, e.gain) for e in sensor.exposures]]),
                   ["%d", _FLOAT, _FLOAT])


def _loader_defaults(sim: Simulation) -> dict[str, object]:
    """The ``meta.json`` keys that change how the folder loads, only where the preset departs
    from the default (folders of the other presets stay byte for byte as they were)."""
    out: dict[str, object] = {}
    if sim.preset.pole_scanner is not None:
        out["pole_scanner"] = dataclasses.asdict(sim.preset.pole_scanner)
    if sim.preset.association is not Association.KNOWN:
        out["association"] = sim.preset.association.value
    if sim.preset.laser_role is not LaserRole.SENSOR:
        out["laser_role"] = sim.preset.laser_role.value
    return out


def _remove_stale_partials(out: Path) -> None:
    """Remove ``.NAME.partial-PID`` folders of writers that no longer run (killed)."""
    for candidate in out.parent.glob(f".{out.name}.partial-*"):
        pid = candidate.name.rsplit("-", 1)[-1]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(candidate, ignore_errors=True)
        except PermissionError:
            pass


def _cv2() -> object:
    from omnislam._optional import require

    return require("cv2")
