"""Image files: a whole PNG or JPEG reads as OpenCV reads it; a truncated or corrupt one is a
DataError naming the file, found before libpng or libjpeg could print on stderr."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.camera.image_file import damage, png_size, read_image
from omnislam.errors import DataError

cv2 = pytest.importorskip("cv2")


@pytest.fixture(params=["png", "jpg"])
def image_file(request, tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / f"image.{request.param}"
    assert cv2.imwrite(str(path), rng.integers(0, 256, (24, 32, 3), dtype=np.uint8))
    return path


def test_a_whole_file_reads_as_opencv_reads_it(image_file):
    np.testing.assert_array_equal(read_image(image_file), cv2.imread(str(image_file)))
    grey = cv2.imread(str(image_file), cv2.IMREAD_GRAYSCALE)
    np.testing.assert_array_equal(read_image(image_file, grey=True), grey)
    assert damage(image_file.read_bytes()) is None


@pytest.mark.parametrize("keep", [0.2, 0.5, 0.99])
def test_a_truncated_file_is_named_before_decoding(image_file, keep, capfd):
    data = image_file.read_bytes()
    image_file.write_bytes(data[: int(len(data) * keep)])
    with pytest.raises(DataError, match="truncated") as info:
        read_image(image_file)
    assert info.value.path == image_file
    assert capfd.readouterr().err == ""


def test_a_png_with_a_damaged_chunk_is_corrupt(tmp_path):
    path = tmp_path / "image.png"
    cv2.imwrite(str(path), np.zeros((24, 32, 3), np.uint8))
    data = bytearray(path.read_bytes())
    data[40] ^= 0xFF  # inside IHDR's data or IDAT: its CRC no longer matches
    path.write_bytes(bytes(data))
    with pytest.raises(DataError, match="corrupt PNG: CRC error"):
        read_image(path)


def test_not_an_image_and_a_missing_file(tmp_path):
    (tmp_path / "notes.png").write_text("hello\n")
    with pytest.raises(DataError, match="not an image file"):
        read_image(tmp_path / "notes.png")
    with pytest.raises(DataError, match="cannot read image"):
        read_image(tmp_path / "absent.png")


def test_the_real_jpegs_are_whole(shared_data):
    for path in sorted((shared_data / "omni_real").rglob("*.jpg")):
        assert damage(path.read_bytes()) is None, path


def test_png_size_reads_the_header_of_a_whole_png(tmp_path, image_file):
    if image_file.suffix == ".png":
        assert png_size(image_file) == (32, 24)
        truncate_to = image_file.read_bytes()[:100]
        (tmp_path / "cut.png").write_bytes(truncate_to)
        with pytest.raises(DataError, match="truncated PNG"):
            png_size(tmp_path / "cut.png")
    else:
        with pytest.raises(DataError, match="not a PNG file"):
            png_size(image_file)
