"""How realistic a render is: the ``realism`` setting of ``omnislam dataset synth`` and grids.

``Realism`` names a level; ``RealismConfig`` holds what that level switches on, one field per
part of the imaging chain (today the camera sensor, ``sensor.SensorConfig``), so that further
parts are added as further fields. ``CLEAN`` is the renderer's own output, byte for byte.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from omnislam.datasets.synthetic.sensor import SensorConfig
from omnislam.errors import ConfigError


class Realism(enum.Enum):
    """How much of a real camera a render imitates."""

    CLEAN = "clean"  # the renderer's images as they are: no sensor, no blur
    REALISTIC = "realistic"  # the camera sensor model (sensor.py) on every image

    @classmethod
    def parse(cls, value: str | Realism, option: str = "realism") -> Realism:
        """The member named ``value``.

        Raises:
            ConfigError: naming ``option`` and the known values.
        """
        if isinstance(value, Realism):
            return value
        try:
            return cls(value)
        except ValueError:
            known = ", ".join(r.value for r in cls)
            raise ConfigError(f"{option}: unknown value {value!r}; known: {known}") from None


@dataclass(frozen=True, slots=True)
class RealismConfig:
    """The parts of the imaging chain a render applies beyond the clean renderer.

    Attributes:
        sensor: the camera sensor model applied to each rendered image (motion blur, noise,
            auto-exposure, vignetting, JPEG); None: the clean image is the recorded one.
            Default None: the clean renders every result so far was measured on.
    """

    sensor: SensorConfig | None = None

    @property
    def is_clean(self) -> bool:
        """True when no part is switched on (the render is the renderer's own output)."""
        return self.sensor is None


def realism_config(realism: Realism | str) -> RealismConfig:
    """The parts a realism level switches on.

    Raises:
        ConfigError: an unknown level.
    """
    realism = Realism.parse(realism)
    if realism is Realism.REALISTIC:
        return RealismConfig(sensor=SensorConfig())
    return RealismConfig()
