"""Real photographs as textures: scikit-image's sample images, and their credits.

The images ship inside scikit-image's wheel (``skimage.data``; extra ``render``), so a render
needs no download. Each is cropped about its centre to the quad's aspect ratio and resized with
scikit-image's anti-aliased ``transform.resize``; grey images are repeated into three channels.

Credits: the images are distributed with scikit-image (BSD-3-Clause licence);
``PHOTO_SOURCES`` gives each one's original source and licence as scikit-image's
``skimage.data`` documentation states them, and ``photo_credit`` the text a dataset's metadata
can carry.
"""

from __future__ import annotations

import numpy as np

from omnislam._optional import require
from omnislam.errors import DataError

#: scikit-image's licence of its package and sample data
SKIMAGE_CREDIT = (
    "Photographic textures from scikit-image's sample data (skimage.data, scikit-image "
    "BSD-3-Clause licence, https://scikit-image.org)"
)

#: sample image -> its original source and licence (from skimage.data's documentation)
PHOTO_SOURCES: dict[str, str] = {
    "astronaut": "Eileen Collins, NASA Great Images database; public domain",
    "coffee": "coffee cup, Pikolo Espresso Bar, photographer Rachel Michetti; CC0",
    "chelsea": "Chelsea the cat, photographer Stefan van der Walt; CC0",
    "rocket": "DSCOVR launch on Falcon 9, SpaceX Photos (Flickr); public domain",
    "hubble_deep_field": "Hubble eXtreme Deep Field, NASA (HubbleSite); public domain",
    "immunohistochemistry": "IHC staining, Center for Microscopy And Molecular Imaging "
                            "(CMMI); no known copyright restrictions",
    "camera": "'camera', photographer Lav Varshney; CC0",
    "coins": "Greek coins from Pompeii, Brooklyn Museum Collection; no known copyright "
             "restrictions",
    "text": "'Corner.png', Wikipedia; public domain",
    "clock": "motion-blurred clock, photographer Stefan van der Walt; public domain",
    "brick": "Bricks25, CC0Textures; CC0",
    "gravel": "Gravel04, CC0Textures; CC0",
    "grass": "Grass-01 by linolafett, DeviantArt; CC0",
}

#: the photographs textures may use (``PHOTO_SOURCES``'s keys, in a fixed order)
PHOTO_NAMES: tuple[str, ...] = tuple(PHOTO_SOURCES)


def photo_credit(names: tuple[str, ...] | list[str] = PHOTO_NAMES) -> str:
    """The credit of photographs ``names``: scikit-image's line, then one line per image.

    Args:
        names: sample images used (unknown names raise DataError); duplicates listed once.
    """
    lines = [SKIMAGE_CREDIT + "; original sources:"]
    for name in sorted(set(names)):
        if name not in PHOTO_SOURCES:
            raise DataError(f"no photograph {name!r} (known: {', '.join(PHOTO_NAMES)})")
        lines.append(f"- skimage.data.{name}: {PHOTO_SOURCES[name]}")
    return "\n".join(lines)


def photo_texels(name: str, size_px: tuple[int, int]) -> np.ndarray:
    """Sample image ``name`` cropped to the aspect of ``size_px`` and resized to it.

    Args:
        name: a key of ``PHOTO_SOURCES``.
        size_px: (width, height) [texels].

    Returns:
        (height, width, 3) float64 RGB in [0, 255], identical on every call.
    """
    if name not in PHOTO_SOURCES:
        raise DataError(f"no photograph {name!r} (known: {', '.join(PHOTO_NAMES)})")
    skimage_data = require("skimage.data")
    transform = require("skimage.transform")
    image = np.asarray(getattr(skimage_data, name)(), dtype=np.float64)
    if image.ndim == 2:
        image = np.repeat(image[..., None], 3, axis=2)
    image = image[..., :3]
    width, height = size_px
    rows, cols = image.shape[:2]
    if cols * height > rows * width:  # wider than the quad: keep the middle columns
        keep = max(1, round(rows * width / height))
        image = image[:, (cols - keep) // 2:(cols - keep) // 2 + keep]
    else:
        keep = max(1, round(cols * height / width))
        image = image[(rows - keep) // 2:(rows - keep) // 2 + keep]
    resized = transform.resize(image, (height, width), order=1, anti_aliasing=True,
                               preserve_range=True)
    return np.clip(resized, 0.0, 255.0)
