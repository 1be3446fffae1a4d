"""``--set key=value`` overrides applied to a component's frozen configuration dataclass.

Options arrive as strings from the command line or a grid YAML; each component declares its
configuration as a tree of frozen dataclasses with typed fields (one section per collaborator:
``association.gate_probability``), and ``apply_options`` converts the strings to those types
(int, float, bool, str, Enum by value, tuples "a,b,c", nested dataclasses by dotted keys such as
``motion_noise.a_vv=0.1``, optional nested configs with ``none``). Unknown keys and
unconvertible values raise ConfigError naming the key, so a typo never passes silently: a key
that lives in a section now names its dotted key, another one the nearest known keys.

A configuration names the few options most users set in a class attribute ``MAIN_OPTIONS``
(dotted keys); ``omnislam estimators`` lists those first and the rest by section (``--all``).
``RENAMED_OPTIONS`` maps flat keys that name an option of a section to its dotted key, for the
one-line hint of an unknown key.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import types
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

from omnislam.errors import ConfigError, did_you_mean, nearest

C = TypeVar("C")

_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


def _convert(key: str, text: str, hint: Any) -> Any:
    origin = typing.get_origin(hint)
    if origin in (types.UnionType, typing.Union):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        if text.strip().lower() in {"none", "null"} and len(args) < len(typing.get_args(hint)):
            return None
        hint = args[0]
        origin = typing.get_origin(hint)
    try:
        if hint is bool:
            lowered = text.strip().lower()
            if lowered not in _TRUE | _FALSE:
                raise ValueError(f"expected true/false, got {text!r}")
            return lowered in _TRUE
        if hint is int:
            return int(text)
        if hint is float:
            value = float(text)
            if math.isnan(value):  # no option means "not a number"; infinity may mean "off"
                raise ValueError("NaN is not a value")
            return value
        if hint is str:
            return text
        if isinstance(hint, type) and issubclass(hint, enum.Enum):
            try:
                return hint(text)
            except ValueError:
                known = ", ".join(str(m.value) for m in hint)
                raise ValueError(f"expected one of {known}, got {text!r}") from None
        if origin is tuple:
            args = typing.get_args(hint)
            parts = [p for p in text.replace(" ", "").split(",") if p]
            element = args[0]
            if len(args) != 2 or args[1] is not Ellipsis:
                if len(parts) != len(args):
                    raise ValueError(f"expected {len(args)} comma-separated values")
                return tuple(_convert(key, p, a) for p, a in zip(parts, args, strict=True))
            return tuple(_convert(key, p, element) for p in parts)
    except ValueError as exc:
        raise ConfigError(f"option {key}: {exc}") from None
    if dataclasses.is_dataclass(hint):
        fields = ", ".join(f"{key}.{f.name}" for f in dataclasses.fields(hint) if f.init)
        raise ConfigError(f"option {key} is a section; set its fields: {fields}")
    raise ConfigError(f"option {key}: cannot be set from the command line")


def apply_options(config: C, options: Mapping[str, str], *, prefix: str = "") -> C:
    """A copy of the dataclass ``config`` with the string ``options`` applied.

    Args:
        config: a (frozen) dataclass instance.
        options: ``{"field": "value", "nested.field": "value"}``.
        prefix: key prefix used in error messages (for nested configs).

    Raises:
        ConfigError: unknown key (naming its dotted key when it lives in a section, else the
            nearest known keys) or a value of the wrong type.
    """
    if not dataclasses.is_dataclass(config) or isinstance(config, type):
        raise TypeError("apply_options needs a dataclass instance")
    if not prefix:
        for key in options:
            _check_key(config, key)
    hints = typing.get_type_hints(type(config))
    fields = {f.name for f in dataclasses.fields(config) if f.init}
    direct: dict[str, Any] = {}
    nested: dict[str, dict[str, str]] = {}
    for key, value in options.items():
        head, _, rest = key.partition(".")
        if head not in fields:
            known = ", ".join(sorted(fields))
            raise ConfigError(f"unknown option {prefix + head!r}; known: {known}")
        if rest:
            nested.setdefault(head, {})[rest] = value
        else:
            direct[head] = _convert(prefix + head, str(value), hints[head])
    for head, sub in nested.items():
        current = direct.get(head, getattr(config, head))
        if current is None:
            hint = hints[head]
            candidates = [a for a in typing.get_args(hint) if dataclasses.is_dataclass(a)]
            if not candidates:
                raise ConfigError(f"option {prefix}{head} has no fields to set")
            current = candidates[0]()
        if not dataclasses.is_dataclass(current):
            raise ConfigError(f"option {prefix}{head} has no fields to set")
        direct[head] = apply_options(current, sub, prefix=f"{prefix}{head}.")
    try:
        return dataclasses.replace(config, **direct)
    except (ValueError, TypeError) as exc:
        keys = ", ".join(prefix + key for key in options)
        raise ConfigError(f"invalid options {keys}: {exc}") from exc


def _check_key(config: Any, key: str) -> None:
    """Raise ConfigError unless ``key`` is an option of ``config``: a field, a dotted field of a
    section, or an optional section itself (``maybe=none``).

    The message of an unknown key names where it went when a section holds a field of that
    name (``'n_particles'; it is set as 'particles.n_particles'``), else the nearest known keys
    (by the whole key, else by the field's name: ``n_particle`` suggests
    ``particles.n_particles``) and the sections.
    """
    leaves = [o.key for o in describe_options(config)]
    sections = sorted({k.rsplit(".", 1)[0] for k in leaves if "." in k})
    if key in leaves or key in sections:
        return
    renamed = renamed_options(config)
    if key in renamed:
        raise ConfigError(f"unknown option {key!r}; it is set as {renamed[key]!r}")
    moved = [k for k in leaves if k.rsplit(".", 1)[-1] == key.rsplit(".", 1)[-1]]
    if len(moved) == 1:
        raise ConfigError(f"unknown option {key!r}; it is set as {moved[0]!r}")
    tails = sorted({k.rsplit(".", 1)[-1] for k in leaves})  # a misspelt field of a section
    near_tails = nearest(key.rsplit(".", 1)[-1], tails, count=3, cutoff=0.7)
    similar = [k for t in near_tails for k in leaves if k.rsplit(".", 1)[-1] == t]
    hint = did_you_mean(key, leaves, count=3, cutoff=0.7, otherwise=moved or similar[:3])
    tops = sorted({k.split(".", 1)[0] for k in leaves})
    if len(tops) > 12:
        heads = sorted({k.split(".", 1)[0] for k in sections})
        known = f"sections: {', '.join(heads)} ('omnislam estimators --all' lists every key)"
    else:
        known = f"known: {', '.join(tops)}"
    raise ConfigError(f"unknown option {key!r}{hint}; {known}")


def renamed_options(config: Any) -> Mapping[str, str]:
    """Earlier keys of options whose name changed when they moved into a section -> their
    dotted keys now (a configuration's ``RENAMED_OPTIONS`` class attribute), for the message
    of an unknown key; a key that only moved, its name kept, needs no entry."""
    return dict(getattr(type(config), "RENAMED_OPTIONS", {}))


def main_options(config: Any) -> tuple[str, ...]:
    """The dotted keys a configuration names as the few that matter (its ``MAIN_OPTIONS``
    class attribute; empty when it names none)."""
    return tuple(getattr(type(config), "MAIN_OPTIONS", ()))


# --------------------------------------------------------------------------------------------
# What the options are: for ``omnislam estimators`` (read from the dataclasses themselves)
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, slots=True)
class OptionDoc:
    """One ``--set`` option of a configuration dataclass.

    Attributes:
        key: the option's key (dotted for nested configurations: ``motion_noise.a_vv``).
        kind: what value it takes ("int", "float", "true|false", "a|b|c" for an enum,
            "float,float,float" for a tuple; "|none" appended when it may be none).
        default: the default as ``--set`` would write it.
        meaning: the field's description from the dataclass's ``Attributes:`` docstring
            section ("" when the docstring has none).
    """

    key: str
    kind: str
    default: str
    meaning: str

    @property
    def summary(self) -> str:
        """The first sentence of ``meaning``."""
        return first_sentence(self.meaning)

    @property
    def section(self) -> str:
        """The section the option lives in (its key up to the last dot; "" at the top)."""
        return self.key.rsplit(".", 1)[0] if "." in self.key else ""


#: words whose full stop does not end a sentence
_ABBREVIATIONS = ("al", "e.g", "i.e", "eq", "eqs", "sec", "fig", "cf", "vs", "approx")


def first_sentence(text: str) -> str:
    """The first sentence of ``text``: up to a full stop followed by a capital, a bracket or
    the end ("eq. 4.41", "e.g. x" and "et al. Table" do not end one)."""
    import re

    flat = " ".join(text.split())
    for match in re.finditer(r"\.(?=\s+[A-Z(\[]|\s*$)", flat):
        word = flat[: match.start()].rsplit(" ", 1)[-1].lower()
        if word not in _ABBREVIATIONS:
            return flat[: match.end()]
    return flat


def attribute_docs(cls: type) -> dict[str, str]:
    """Field name -> description, from the ``Attributes:`` section of ``cls``'s docstring
    (Google style; an entry may name several fields: ``alpha, beta, kappa: ...``)."""
    import inspect
    import re

    lines = (inspect.getdoc(cls) or "").splitlines()
    out: dict[str, str] = {}
    try:
        start = next(i for i, line in enumerate(lines) if line.strip() == "Attributes:")
    except StopIteration:
        return out
    base: int | None = None
    names: list[str] = []
    entry = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(?:\s*,\s*[A-Za-z_][A-Za-z0-9_]*)*)\s*:\s?(.*)$")
    for line in lines[start + 1 :]:
        if not line.strip():
            continue
        indent = len(line) - len(line.lstrip())
        if indent == 0:
            break  # the next section
        if base is None:
            base = indent
        match = entry.match(line.strip()) if indent == base else None
        if match:
            names = [n.strip() for n in match.group(1).split(",")]
            for name in names:
                out[name] = match.group(2).strip()
        elif indent > base and names:
            for name in names:
                out[name] = f"{out[name]} {line.strip()}".strip()
        elif indent <= base:
            break
    return out


def _kind(hint: Any) -> tuple[str, bool]:
    """(kind text, may be none) of a field's type hint."""
    optional = False
    origin = typing.get_origin(hint)
    if origin in (types.UnionType, typing.Union):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        optional = len(args) < len(typing.get_args(hint))
        hint = args[0]
        origin = typing.get_origin(hint)
    if hint is bool:
        return "true|false", optional
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        return "|".join(str(m.value) for m in hint), optional
    if origin is tuple:
        args = typing.get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"{_kind(args[0])[0]},...", optional
        return ",".join(_kind(a)[0] for a in args), optional
    return getattr(hint, "__name__", str(hint)), optional


def _text(value: Any) -> str:
    """A value as ``--set`` would write it."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, enum.Enum):
        return str(value.value)
    if isinstance(value, tuple):
        return ",".join(_text(v) for v in value)
    if isinstance(value, float):
        return repr(value)  # the shortest text that reads back as the same float
    return str(value)


def describe_options(config: Any, *, prefix: str = "") -> list[OptionDoc]:
    """Every option ``apply_options`` accepts on ``config``, with its default and meaning.

    Nested dataclasses are expanded into dotted keys; an optional nested configuration that is
    None by default is listed once (``key = none``) and then by its fields' defaults.
    """
    if not dataclasses.is_dataclass(config) or isinstance(config, type):
        raise TypeError("describe_options needs a dataclass instance")
    hints = typing.get_type_hints(type(config))
    docs = attribute_docs(type(config))
    out: list[OptionDoc] = []
    for f in dataclasses.fields(config):
        if not f.init:
            continue
        value = getattr(config, f.name)
        key = prefix + f.name
        hint = hints[f.name]
        nested_type = None
        if dataclasses.is_dataclass(value):
            nested_type = type(value)
        else:
            candidates = [a for a in typing.get_args(hint) if dataclasses.is_dataclass(a)]
            nested_type = candidates[0] if candidates else None
        if nested_type is not None:
            if value is None:
                out.append(OptionDoc(key, "none|fields below", "none", docs.get(f.name, "")))
                value = nested_type()
            out.extend(describe_options(value, prefix=key + "."))
            continue
        kind, optional = _kind(hint)
        out.append(
            OptionDoc(
                key, kind + ("|none" if optional else ""), _text(value), docs.get(f.name, "")
            )
        )
    return out
