"""Type checks for the fields of a frozen config dataclass, driven by its annotations.

Every config in this package calls :func:`coerce_fields` first thing in ``__post_init__``, so a
value of the wrong kind is one clear error naming the field, the value and what is allowed,
instead of a ``TypeError`` from deep inside the world or Box2D later:

* ``bool``: ``True``/``False`` only (also numpy booleans). ``"false"`` is a string, and a string is
  never quietly taken as true;
* ``int``: integers, numpy integers included; not booleans, not ``1.7``;
* ``float``: any real number (numpy included), finite, and within ``±max_magnitude`` (the world is
  simulated in float32: farther values lose centimetres, larger ones overflow);
* ``str``; ``Optional[X]``; ``Union[...]``; ``tuple[X, ...]``; ``tuple[X, Y]``.

Values are converted to the plain Python type (``np.int64(3)`` -> ``3``, lists -> tuples).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import typing
from typing import Any, Callable, Union

import numpy as np

MAX_MAGNITUDE = 1e4  # metres, seconds, m/s, rewards: no sensible value of this package is larger


class FieldError(ValueError):
    """One field's value is not of its declared kind (the caller raises its own error type)."""


def _describe(kind: Any) -> str:
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if kind is bool:
        return "True or False"
    if kind is int:
        return "an integer"
    if kind is float:
        return "a finite number"
    if kind is str:
        return "a string"
    if kind is type(None):
        return "None"
    if origin is Union:
        return " or ".join(_describe(a) for a in args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"a sequence of {_describe(args[0]).removeprefix('a ').removeprefix('an ')}s"
        return f"a sequence of {len(args)} values ({', '.join(_describe(a) for a in args)})"
    return getattr(kind, "__name__", str(kind))


def coerce(name: str, value: Any, kind: Any, max_magnitude: float = MAX_MAGNITUDE) -> Any:
    """``value`` as the plain Python value of type ``kind``; :class:`FieldError` if it is not one."""
    origin, args = typing.get_origin(kind), typing.get_args(kind)

    def bad(extra: str = "") -> FieldError:
        return FieldError(f"{name} must be {_describe(kind)}{extra}, got {value!r}")

    if kind is bool:
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        raise bad()
    if kind is int:
        if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)):
            return int(value)
        raise bad()
    if kind is float:
        if not isinstance(value, numbers.Real) or isinstance(value, (bool, np.bool_)):
            raise bad()
        try:
            out = float(value) + 0.0  # + 0.0 turns -0.0 into 0.0 (numpy's uniform(0.0, -0.0) fails)
        except OverflowError:  # an integer beyond float range
            raise bad(f" within ±{max_magnitude:g}") from None
        if not math.isfinite(out) or abs(out) > max_magnitude:
            raise bad(f" within ±{max_magnitude:g}")
        return out
    if kind is str:
        if isinstance(value, str):
            return value
        raise bad()
    if kind is type(None):
        if value is None:
            return None
        raise bad()
    if origin is Union:
        if value is None and type(None) in args:
            return None
        for option in args:
            if option is type(None):
                continue
            try:
                return coerce(name, value, option, max_magnitude)
            except FieldError:
                continue
        raise bad()
    if origin is tuple:
        if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__iter__"):
            raise bad()
        try:
            items = list(value)
        except TypeError:  # iterable in name only: a 0-d numpy array
            raise bad() from None
        if len(args) == 2 and args[1] is Ellipsis:
            kinds = [args[0]] * len(items)
        else:
            if len(items) != len(args):
                raise bad()
            kinds = list(args)
        return tuple(coerce(f"{name}[{i}]", v, k, max_magnitude) for i, (v, k) in enumerate(zip(items, kinds)))
    return value  # a kind this module does not check (callables, dicts): left to the config


def coerce_fields(cfg: Any, error: Callable[[str], Exception],
                  skip: tuple[str, ...] = ()) -> None:
    """Check and convert every field of the frozen dataclass ``cfg`` in place; raise
    ``error(message)`` for the first bad one."""
    hints = typing.get_type_hints(type(cfg))
    for f in dataclasses.fields(cfg):
        if f.name in skip or f.name.startswith("_"):
            continue
        try:
            value = coerce(f.name, getattr(cfg, f.name), hints[f.name])
        except FieldError as exc:
            raise error(f"{type(cfg).__name__}: {exc}") from None
        object.__setattr__(cfg, f.name, value)


def check_bounds(cfg: Any, bounds: dict[str, tuple[Any, Any]], error: Callable[[str], Exception],
                 above: tuple[str, ...] = ()) -> None:
    """Every named field within its ``(low, high)`` (either may be None for no bound); fields in
    ``above`` must be strictly greater than ``low``. A None value is skipped (Optional fields)."""
    for name, (low, high) in bounds.items():
        value = getattr(cfg, name)
        if value is None:
            continue
        strict = name in above
        if (low is not None and (value <= low if strict else value < low)) or (high is not None and value > high):
            parts = ([f"> {low}" if strict else f">= {low}"] if low is not None else []) + \
                    ([f"<= {high}"] if high is not None else [])
            raise error(f"{type(cfg).__name__}: {name} must be {' and '.join(parts)}, got {value!r}")
