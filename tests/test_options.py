import enum
from dataclasses import dataclass, field

import pytest

from omnislam.errors import ConfigError
from omnislam.options import apply_options


class Mode(enum.Enum):
    FAST = "fast"
    SLOW = "slow"


@dataclass(frozen=True)
class Inner:
    a: float = 1.0
    b: int = 2


@dataclass(frozen=True)
class Outer:
    n: int = 10
    ratio: float = 0.5
    flag: bool = False
    mode: Mode = Mode.FAST
    sigmas: tuple[float, float, float] = (0.1, 0.1, 0.1)
    inner: Inner = field(default_factory=Inner)
    maybe: Inner | None = None
    label: str = "x"


def test_every_supported_type_converts():
    out = apply_options(
        Outer(),
        {
            "n": "50",
            "ratio": "0.25",
            "flag": "yes",
            "mode": "slow",
            "sigmas": "1,2,3",
            "inner.a": "7.5",
            "maybe.b": "9",
            "label": "hello",
        },
    )
    assert out == Outer(
        50, 0.25, True, Mode.SLOW, (1.0, 2.0, 3.0), Inner(7.5, 2), Inner(1.0, 9), "hello"
    )
    assert apply_options(out, {"maybe": "none"}).maybe is None


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"nn": "1"}, "unknown option 'nn'; known: flag, inner"),
        ({"n": "ten"}, "option n:"),
        ({"mode": "medium"}, "expected one of fast, slow"),
        ({"flag": "maybe"}, "expected true/false"),
        ({"sigmas": "1,2"}, "expected 3 comma-separated values"),
        ({"inner.c": "1"}, "unknown option 'inner.c'"),
    ],
)
def test_bad_options_name_the_key(options, message):
    with pytest.raises(ConfigError, match=message):
        apply_options(Outer(), options)


def test_validation_of_the_config_itself_is_kept():
    from omnislam.fastslam import FastSLAMConfig

    with pytest.raises(ConfigError, match=r"particles\.n_particles must be >= 1"):
        apply_options(FastSLAMConfig(), {"particles.n_particles": "0"})
    config = apply_options(
        FastSLAMConfig(), {"motion_noise.a_vv": "0.2", "particles.store": "dense"}
    )
    assert config.motion_noise.a_vv == 0.2 and config.particles.store.value == "dense"


@dataclass(frozen=True)
class Solver:
    threshold: float = 0.1
    skip: int = 1


@dataclass(frozen=True)
class Sectioned:
    MAIN_OPTIONS = ("solver.threshold",)

    n_particles: int = 10
    solver: Solver = field(default_factory=Solver)


def test_a_key_that_lives_in_a_section_names_its_dotted_key():
    with pytest.raises(ConfigError, match=r"unknown option 'threshold'; it is set as "
                       r"'solver.threshold'"):
        apply_options(Sectioned(), {"threshold": "0.2"})
    assert apply_options(Sectioned(), {"solver.threshold": "0.2"}).solver.threshold == 0.2


def test_a_section_given_a_value_names_its_fields():
    fields = r"option solver is a section; set its fields: solver.threshold, solver.skip$"
    with pytest.raises(ConfigError, match=fields):
        apply_options(Sectioned(), {"solver": "on"})


def test_a_misspelt_key_gets_the_nearest_known_ones():
    with pytest.raises(ConfigError, match=r"'n_particle' \(did you mean 'n_particles'\?\)"):
        apply_options(Sectioned(), {"n_particle": "5"})
    with pytest.raises(ConfigError, match=r"'solver.skp' \(did you mean 'solver.skip'\?\)"):
        apply_options(Sectioned(), {"solver.skp": "5"})


def test_main_options_come_from_the_class_attribute():
    from omnislam.options import describe_options, main_options

    assert main_options(Sectioned()) == ("solver.threshold",)
    assert main_options(Outer()) == ()
    assert [o.section for o in describe_options(Sectioned())] == ["", "solver", "solver"]
