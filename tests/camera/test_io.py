"""YAML files of every camera model and of the rig; malformed files raise DataError."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from camera_checks import MODEL_NAMES, model

from omnislam.camera import (
    CAMERA_MODELS,
    CameraRig,
    HyperbolicCamera,
    camera_from_dict,
    load_camera,
    load_rig,
    save_camera,
    save_rig,
)
from omnislam.errors import DataError


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_yaml_round_trip_returns_an_equal_camera(name, tmp_path):
    camera = model(name)
    path = tmp_path / "camera.yaml"
    save_camera(camera, path)
    loaded = load_camera(path)
    assert type(loaded) is type(camera) and loaded == camera
    assert path.read_text().startswith(f"model: {camera.MODEL}\n")


def test_every_model_is_registered_and_defaults_may_be_omitted():
    assert set(CAMERA_MODELS) == {"hyperbolic", "unified", "ocamcalib", "pinhole"}
    assert camera_from_dict({"model": "hyperbolic"}) == HyperbolicCamera()
    short = {
        "model": "pinhole",
        "fx": 500,
        "fy": 500,
        "cu": 320,
        "cv": 240,
        "width": 640,
        "height": 480,
    }
    assert camera_from_dict(short).fx == 500.0 and isinstance(camera_from_dict(short).fx, float)


def test_rig_round_trip_and_hand_written_file(tmp_path):
    rTc = np.eye(4)
    rTc[:3, 3] = [0.1, 0.0, 0.45]
    rig = CameraRig(model("hyperbolic"), rTc)
    path = tmp_path / "calibration.yaml"
    save_rig(rig, path)
    assert load_rig(path) == rig
    path.write_text(
        "camera:\n  model: pinhole\n  fx: 400\n  fy: 400\n  cu: 319.5\n  cv: 239.5\n"
        "  width: 640\n  height: 480\n"
        "rTc: [[0, 0, 1, 0.2], [-1, 0, 0, 0], [0, -1, 0, 0.3], [0, 0, 0, 1]]\n"
    )
    loaded = load_rig(path)
    assert loaded.camera.MODEL == "pinhole"
    assert np.allclose(loaded.viewpoint_r, [0.2, 0.0, 0.3])


BAD_CAMERAS = [
    ("model: fisheye\n", "unknown camera model 'fisheye'"),
    ("a_m: 0.03\n", "missing key 'model'"),
    ("model: pinhole\nfx: 400\n", "missing key\\(s\\) for model 'pinhole': cu, cv, fy, height"),
    ("model: hyperbolic\na_m: 0.03\nfocal: 0.006\n", "unknown key\\(s\\).*focal"),
    ("model: hyperbolic\na_m: thirty\n", "HyperbolicCamera.a_m must be a number"),
    ("model: hyperbolic\nwidth: 640.5\n", "HyperbolicCamera.width must be an integer"),
    ("model: hyperbolic\nwidth: true\n", "HyperbolicCamera.width must be an integer"),
    ("model: hyperbolic\nz_h_m: 0.05\n", "non-central"),
    ("model: hyperbolic\na_m: -0.03\n", "a_m must be positive"),
    ("model: ocamcalib\npol: [1, x]\n", "pol must be a list of numbers"),
    ("- just\n- a list\n", "must be a mapping"),
    ("model: [unclosed\n", "not valid YAML"),
]


@pytest.mark.parametrize(("text", "message"), BAD_CAMERAS)
def test_malformed_camera_files_raise_data_error_naming_the_file(tmp_path, text, message):
    path = tmp_path / "camera.yaml"
    path.write_text(text)
    with pytest.raises(DataError, match=message) as info:
        load_camera(path)
    assert info.value.path == path and str(path) in str(info.value)


BAD_RIGS = [
    ("camera: {model: hyperbolic}\n", "missing key\\(s\\) for a camera rig: rTc"),
    ("camera: {model: hyperbolic}\nrTc: [[1, 0], [0, 1]]\n", "finite \\(4, 4\\)"),
    (
        "camera: {model: hyperbolic}\n"
        "rTc: [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n",
        "orthogonal",
    ),
    (
        "camera: {model: nope}\nrTc: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n",
        "unknown camera model",
    ),
    ("camera: {model: hyperbolic}\nrTc: [[a]]\nextra: 1\n", "unknown key\\(s\\).*extra"),
]


@pytest.mark.parametrize(("text", "message"), BAD_RIGS)
def test_malformed_rig_files_raise_data_error_naming_the_file(tmp_path, text, message):
    path = tmp_path / "calibration.yaml"
    path.write_text(text)
    with pytest.raises(DataError, match=message) as info:
        load_rig(path)
    assert info.value.path == path


def test_missing_file_names_the_file(tmp_path):
    with pytest.raises(DataError, match="cannot read") as info:
        load_camera(tmp_path / "absent.yaml")
    assert info.value.path == tmp_path / "absent.yaml"


def test_models_are_frozen():
    camera = HyperbolicCamera()
    with pytest.raises(dataclasses.FrozenInstanceError):
        camera.a_m = 1.0  # type: ignore[misc]
    assert not hasattr(camera, "__dict__")  # slots
