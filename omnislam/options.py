"""``--set key=value`` overrides applied to a component's frozen configuration dataclass.

Options arrive as strings from the command line or a grid YAML; each component declares its
configuration as a frozen dataclass with typed fields, and ``apply_options`` converts the strings
to those types (int, float, bool, str, Enum by value, tuples "a,b,c", nested dataclasses by
dotted keys such as ``motion_noise.a_vv=0.1``, optional nested configs with ``none``). Unknown
keys and unconvertible values raise ConfigError naming the key, so a typo never passes silently.
"""

from __future__ import annotations

import dataclasses
import enum
import types
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

from omnislam.errors import ConfigError

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
            return float(text)
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
    raise ConfigError(f"option {key}: cannot be set from the command line")


def apply_options(config: C, options: Mapping[str, str], *, prefix: str = "") -> C:
    """A copy of the dataclass ``config`` with the string ``options`` applied.

    Args:
        config: a (frozen) dataclass instance.
        options: ``{"field": "value", "nested.field": "value"}``.
        prefix: key prefix used in error messages (for nested configs).

    Raises:
        ConfigError: unknown key (the known ones are listed) or a value of the wrong type.
    """
    if not dataclasses.is_dataclass(config) or isinstance(config, type):
        raise TypeError("apply_options needs a dataclass instance")
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
        raise ConfigError(f"invalid options {', '.join(options)}: {exc}") from exc
