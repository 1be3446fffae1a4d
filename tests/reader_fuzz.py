"""Mutation fuzzing of omnislam's readers: small valid inputs, mutated, read in-process.

Every reader is given a small valid input (``build_targets``); a mutation (``mutate``) changes
one of its files: cut at any byte, a line dropped, duplicated or swapped, a number replaced by
NaN, inf, 1e308, its negative, text or a huge count, a wrong encoding, an empty file, and for
``.npz`` files an array's element, length or type. ``check`` reads the mutated copy and
demands the invariant of the README: the reader returns sane output, or raises the package's
``DataError`` / ``ConfigError`` with a message that names the input (its file or folder);
anything else, or a read that outlives ``TIME_LIMIT_S``, is a violation.

The choices of a mutation come from a ``Chooser``: hypothesis draws them in the tests
(tests/datasets/test_fuzz_readers.py, shrinking a failure to its smallest mutation), a seeded
generator in the long run (benchmarks/fuzz_readers.py).
"""

from __future__ import annotations

import io
import re
import shutil
import signal
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
from room_log import write_room_log

from omnislam.errors import ConfigError, DataError

#: longest a reader may take on one mutated input [s] (the valid inputs read in < 1 s)
TIME_LIMIT_S = 20.0

#: what replaces a number of a text file (the README's list: NaN, inf, 1e308, text, a huge
#: count; the number's negative is added by ``_replace_number``)
NUMBER_REPLACEMENTS = ("nan", "inf", "-inf", "1e308", "-1e308", "x", "1000000000000", "0", "-1")

_NUMBER = re.compile(rb"(?<![\w.])-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")


class Chooser(Protocol):
    """Where a mutation's choices come from (hypothesis or a seeded generator)."""

    def integer(self, low: int, high: int) -> int:
        """An integer in [low, high]."""
        ...


class RandomChooser:
    """Choices from a seeded numpy generator (the long run)."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def integer(self, low: int, high: int) -> int:
        return int(self.rng.integers(low, high + 1))


@dataclass(frozen=True, slots=True)
class Target:
    """A reader and its small valid input.

    Attributes:
        name: the reader, as the tests' ids show it.
        pristine: the valid input (a file or a folder), never mutated.
        files: the input's files a mutation may change (relative to ``pristine`` for a folder,
            ``("",)`` for a single file).
        read: reads the input (its path); returns the reader's output.
        sane: True when an output of ``read`` is sane (finite, ordered, not empty).
    """

    name: str
    pristine: Path
    files: tuple[str, ...]
    read: Callable[[Path], object]
    sane: Callable[[object], bool]


@dataclass(frozen=True, slots=True)
class Outcome:
    """What reading one mutated input gave.

    Attributes:
        violation: None when the invariant holds, else what broke it (one line).
        mutation: the mutation applied (one line).
        refusal: the error's message when the reader refused the input, else None.
    """

    violation: str | None
    mutation: str
    refusal: str | None = None


# ---- mutations ---------------------------------------------------------------------------------


def _lines(data: bytes) -> list[bytes]:
    return data.splitlines(keepends=True)


def _text_mutation(data: bytes, choose: Chooser) -> tuple[bytes, str]:
    """One mutation of a text file's bytes and its description."""
    lines = _lines(data)
    kind = choose.integer(0, 7)
    if kind == 0 or not lines:
        at = choose.integer(0, max(len(data) - 1, 0))
        return data[:at], f"cut at byte {at}"
    i = choose.integer(0, len(lines) - 1)
    if kind == 1:
        return b"".join(lines[:i] + lines[i + 1 :]), f"line {i + 1} dropped"
    if kind == 2:
        return b"".join(lines[: i + 1] + lines[i:]), f"line {i + 1} duplicated"
    if kind == 3:
        j = choose.integer(0, len(lines) - 1)
        lines[i], lines[j] = lines[j], lines[i]
        return b"".join(lines), f"lines {i + 1} and {j + 1} swapped"
    if kind in (4, 5):
        return _replace_number(data, choose)
    if kind == 6:
        encoding = ("utf-16", "utf-32", "latin-1-bytes")[choose.integer(0, 2)]
        if encoding == "latin-1-bytes":
            at = choose.integer(0, max(len(data) - 1, 0))
            return data[:at] + b"\xe9\xff\xfe" + data[at:], f"latin-1 bytes at {at}"
        return data.decode("utf-8", "replace").encode(encoding), f"encoded as {encoding}"
    return b"", "emptied"


def _replace_number(data: bytes, choose: Chooser) -> tuple[bytes, str]:
    numbers = list(_NUMBER.finditer(data))
    if not numbers:
        return data[: len(data) // 2], "cut in half (no number)"
    match = numbers[choose.integer(0, len(numbers) - 1)]
    options = (*NUMBER_REPLACEMENTS, "negative")
    new = options[choose.integer(0, len(options) - 1)]
    old = match.group().decode()
    if new == "negative":
        new = old[1:] if old.startswith("-") else "-" + old
    mutated = data[: match.start()] + new.encode() + data[match.end() :]
    return mutated, f"number {old} at byte {match.start()} -> {new}"


def _binary_mutation(data: bytes, choose: Chooser) -> tuple[bytes, str]:
    """One mutation of a binary file's bytes (an image, an npz's container)."""
    kind = choose.integer(0, 2)
    if kind == 0:
        at = choose.integer(0, max(len(data) - 1, 0))
        return data[:at], f"cut at byte {at}"
    if kind == 1 and data:
        at = choose.integer(0, len(data) - 1)
        count = choose.integer(1, 16)
        return data[:at] + bytes(count) + data[at + count :], f"{count} bytes zeroed at {at}"
    return b"", "emptied"


def _array_mutation(data: bytes, choose: Chooser) -> tuple[bytes, str]:
    """One mutation of one array of an ``.npz`` file (saved again, compressed)."""
    with np.load(io.BytesIO(data), allow_pickle=False) as archive:
        arrays = {key: archive[key] for key in archive.files}
    if not arrays:
        return _binary_mutation(data, choose)
    key = sorted(arrays)[choose.integer(0, len(arrays) - 1)]
    array = arrays[key]
    kind = choose.integer(0, 4)
    if kind == 0 and array.size and array.dtype.kind in "fiu":
        values = (np.nan, np.inf, 1e308, -1.0, 1e12)
        value = values[choose.integer(0, len(values) - 1)]
        index = choose.integer(0, array.size - 1)
        changed = array.copy()
        try:
            changed.flat[index] = value
        except (ValueError, OverflowError):  # NaN or 1e12 in an integer array: floats then
            changed = array.astype(float)
            changed.flat[index] = value
        arrays[key], what = changed, f"{key}[{index}] = {value}"
    elif kind == 1 and array.ndim and len(array):
        arrays[key], what = array[:-1], f"{key}: last row dropped"
    elif kind == 2 and array.ndim and len(array):
        arrays[key], what = np.concatenate([array, array[-1:]]), f"{key}: last row doubled"
    elif kind == 3:
        arrays[key], what = np.array("text"), f"{key}: replaced by a string"
    else:
        del arrays[key]
        what = f"{key}: removed"
    out = io.BytesIO()
    np.savez_compressed(out, **arrays)
    return out.getvalue(), what


def mutate(path: Path, choose: Chooser) -> str:
    """Mutate the file ``path`` in place; return what was done."""
    data = path.read_bytes()
    if path.suffix == ".npz":
        if choose.integer(0, 1):
            mutated, what = _array_mutation(data, choose)
        else:
            mutated, what = _binary_mutation(data, choose)
    elif path.suffix in {".png", ".jpg", ".gz"}:
        mutated, what = _binary_mutation(data, choose)
    else:
        mutated, what = _text_mutation(data, choose)
    path.write_bytes(mutated)
    return what


# ---- the invariant ---------------------------------------------------------------------------


class _TimeLimitError(Exception):
    """A reader outlived ``TIME_LIMIT_S``."""


def _on_alarm(_signum: int, _frame: object) -> None:
    raise _TimeLimitError


def check(target: Target, workdir: Path, choose: Chooser) -> Outcome:
    """Copy the target's input into ``workdir``, mutate one file, read it, judge the result."""
    copy = workdir / target.pristine.name
    if target.pristine.is_dir():
        shutil.copytree(target.pristine, copy)
    else:
        shutil.copy(target.pristine, copy)
    relative = target.files[choose.integer(0, len(target.files) - 1)]
    mutation = f"{relative or copy.name}: {mutate(copy / relative if relative else copy, choose)}"
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT_S)
    try:
        output = target.read(copy)
    except (DataError, ConfigError) as exc:
        message = str(exc)
        if copy.name not in message:
            return Outcome(f"{type(exc).__name__} not naming the input: {message}", mutation)
        if "\n" in message.strip():
            return Outcome(f"{type(exc).__name__} of several lines: {message!r}", mutation)
        return Outcome(None, mutation, message)
    except _TimeLimitError:
        return Outcome(f"no answer within {TIME_LIMIT_S:g} s", mutation)
    except Exception as exc:  # any other exception is what the fuzzing looks for
        return Outcome(f"{type(exc).__name__}: {exc}", mutation)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)
    if not target.sane(output):
        return Outcome("returned output that is not sane", mutation)
    return Outcome(None, mutation)


# ---- the readers and their small valid inputs ------------------------------------------------


def _finite_ordered(stamps_s: np.ndarray) -> bool:
    stamps_s = np.asarray(stamps_s, dtype=float)
    return bool(len(stamps_s) and np.all(np.isfinite(stamps_s)) and np.all(np.diff(stamps_s) >= 0))


def sequence_sane(sequence: object) -> bool:
    """A Sequence with frames, finite ordered stamps and finite odometry."""
    from omnislam.datasets.sequence import Sequence

    return (
        isinstance(sequence, Sequence)
        and _finite_ordered(sequence.stamps_s)
        and bool(np.all(np.isfinite(sequence.odometry_r)))
    )


def _instance_of(cls: type) -> Callable[[object], bool]:
    return lambda output: isinstance(output, cls)


def _mrclam_folder(root: Path) -> Path:
    folder = root / "MRCLAM_Fuzz"
    folder.mkdir()
    odometry = np.arange(0.0, 10.0 + 1e-9, 0.1)
    sightings = np.arange(1.0, 9.0 + 1e-9, 0.5)
    files = {
        "Barcodes.dat": "# subject barcode\n1 5\n6 63\n7 27\n",
        "Landmark_Groundtruth.dat": "# subject x y sx sy\n6 2.0 0.5 0.001 0.001\n"
        "7 -1.0 1.5 0.001 0.001\n",
        "Robot1_Odometry.dat": "# time v omega\n"
        + "".join(f"{t:.3f} 0.1 0.05\n" for t in odometry),
        "Robot1_Measurement.dat": "# time barcode range bearing\n"
        + "".join(f"{t:.3f} {63 if k % 2 else 27} 1.5 0.2\n" for k, t in enumerate(sightings)),
        "Robot1_Groundtruth.dat": "# time x y theta\n"
        + "".join(f"{t:.3f} {0.1 * t:.4f} 0.0 {0.05 * t:.4f}\n" for t in odometry),
    }
    for name, text in files.items():
        (folder / name).write_text(text)
    return folder


def _victoria_folder(root: Path) -> Path:
    folder = root / "park"
    folder.mkdir()
    files = {
        "inputs.dat": "".join(f"{t:.3f} 2.0 0.01\n" for t in np.arange(0.0, 5.0 + 1e-9, 0.025)),
        "measurements.dat": "".join(
            f"{t:.3f} 8.0 1.2 0.3\n" for t in np.arange(0.5, 4.6, 0.5)
        ),
        "gps.dat": "".join(f"{t:.3f} {2 * t:.3f} 0.0\n" for t in np.arange(0.0, 5.01, 0.2)),
    }
    for name, text in files.items():
        (folder / name).write_text(text)
    return folder


def _gtsam_graph(root: Path) -> Path:
    path = root / "graph.txt"
    chain = "".join(
        f"ODOMETRY {i} {i + 1} 1 0 0.1 0.0001 0 0 4e-06 0 4e-06\n" for i in range(6)
    )
    sightings = "LANDMARK 2 100 1 0.4 0.4 0 0.4\nBR 3 101 0.3 5 0.1 0.05\nBR 5 101 0.2 4 0.1 0.05\n"
    path.write_text(chain + sightings)
    return path


def _synthetic_folder(root: Path) -> Path:
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic

    folder = root / "synth"
    write_synthetic(folder, simulate(PRESETS["demo"], 0, max_images=3))
    return folder


def _bearing_folder(root: Path) -> Path:
    """An omnislam folder of bearing-only sightings (elevations, both sigmas) and a laser
    turned by its offset."""
    import json

    folder = root / "omnislam-folder-bearings"
    folder.mkdir()
    (folder / "dataset.json").write_text(json.dumps({
        "format": "omnislam-folder", "version": 1, "source": "fuzz", "licence": "CC0-1.0",
        "sightings": {"height_m": 0.5, "offset_r": [0.0, 0.0, 0.1]},
        "laser": {"angles_rad": [-0.5, 0.0, 0.5], "max_range_m": 8.0,
                  "offset_r": [0.0, 0.0, 0.2]},
    }))
    (folder / "odometry.csv").write_text(
        "stamp_s,dx_m,dy_m,dtheta_rad\n0.0,0,0,0\n0.5,0.2,0,0.05\n1.0,0.2,0,0.05\n")
    (folder / "sightings.csv").write_text(
        "stamp_s,landmark_id,bearing_rad,elevation_rad,sigma_bearing_rad,sigma_elevation_rad\n"
        "0.5,1,0.5,0.25,0.01,0.01\n0.5,,-0.5,,0.02,\n1.0,1,0.6,0.2,0.01,0.01\n")
    (folder / "laser.csv").write_text(
        "stamp_s,range_0_m,range_1_m,range_2_m\n0.5,2.0,3.0,\n1.0,2.5,8.0,1.0\n")
    return folder


def _files(folder: Path) -> tuple[str, ...]:
    return tuple(sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()))


def _single(name: str, path: Path, read: Callable[[Path], object],
            sane: Callable[[object], bool]) -> Target:
    return Target(name, path, ("",), read, sane)


def _folder(name: str, path: Path, read: Callable[[Path], object],
            sane: Callable[[object], bool], files: tuple[str, ...] | None = None) -> Target:
    return Target(name, path, files if files is not None else _files(path), read, sane)


def build_targets(root: Path, *, images: bool = True) -> dict[str, Target]:
    """Write a small valid input of every reader under ``root``; ``images``: also the readers
    whose inputs need the synthetic renderer (opencv)."""
    from omnislam.camera.io import load_rig
    from omnislam.cli import main
    from omnislam.datasets.carmen import load_carmen
    from omnislam.datasets.folder import load_folder
    from omnislam.datasets.folder.loader import check_folder
    from omnislam.datasets.folder.writer import export_folder
    from omnislam.datasets.gtsam_victoria import load_gtsam_victoria
    from omnislam.datasets.mrclam import load_mrclam
    from omnislam.datasets.victoria_park import load_victoria_park
    from omnislam.frontend.observation_log import ObservationLog, load_observation_log
    from omnislam.harness.grid import Grid, load_grid
    from omnislam.harness.rundir import RunRecord, read_run_dir

    root.mkdir(parents=True, exist_ok=True)
    log = write_room_log(root / "carmen" / "room.log", frames=20)
    run_dir, obs = root / "run", root / "obs.npz"
    assert main(["run", str(log), "--estimator", "deadreckoning", "--out", str(run_dir)]) == 0
    assert main(["frontend", str(log), "--out", str(obs)]) == 0
    folder = export_folder(load_carmen(log), root / "omnislam-folder")
    grid = root / "grid.yaml"
    grid.write_text(
        f"datasets: [{log}]\nseeds: [1, 2]\nestimators:\n  - deadreckoning\n"
        "  - {estimator: ekfslam, options: {association.gate_probability: 0.99}}\n"
        "evaluation: {rpe_segment_m: 2.0, curve_lengths: 3}\n"
    )
    targets = [
        _folder("mrclam", _mrclam_folder(root), load_mrclam, sequence_sane),
        _folder("victoria-park", _victoria_folder(root), load_victoria_park, sequence_sane),
        _single("gtsam-graph", _gtsam_graph(root), load_gtsam_victoria, sequence_sane),
        _single("carmen", log, load_carmen, sequence_sane),
        _single("observation-log", obs, load_observation_log, _instance_of(ObservationLog)),
        _folder("run-dir", run_dir, read_run_dir, _instance_of(RunRecord)),
        _single("grid", grid, load_grid, _instance_of(Grid)),
        _folder("omnislam-folder", Path(folder), load_folder, sequence_sane),
        _folder("omnislam-folder-check", Path(folder), check_folder,
                lambda problems: isinstance(problems, list)),
        _folder("omnislam-folder-bearings", _bearing_folder(root), load_folder, sequence_sane),
    ]
    if images:
        from omnislam.camera.rig import CameraRig
        from omnislam.datasets.synthetic import load_synthetic

        synthetic = _synthetic_folder(root)
        camera = root / "calibration.yaml"
        shutil.copy(synthetic / "calibration.yaml", camera)
        targets += [
            _folder("synthetic", synthetic, load_synthetic, sequence_sane,
                    tuple(f for f in _files(synthetic) if not f.startswith("gt/"))),
            _single("camera", camera, load_rig, _instance_of(CameraRig)),
        ]
    return {target.name: target for target in targets}
