"""A dataclass of arguments is the CLI (CleanRL style): ``--field-name value`` per field."""

from __future__ import annotations

import argparse
import dataclasses
import sys
import typing
from typing import Any, Optional, Sequence, TypeVar, cast

from box2d_driving.cli_parser import OneLineParser

__all__ = ["OneLineParser", "error", "parse", "prog_name"]

T = TypeVar("T")


def prog_name() -> str:
    """The command as typed: ``box2d-driving evaluate`` through the CLI (which sets ``argv[0]``),
    the script's file name when run as a script. Every error line starts ``PROG: error:``."""
    return sys.argv[0].rsplit("/", 1)[-1]


def error(message: str) -> int:
    """Print the one-line error every command uses; returns the usage-error status, 2."""
    print(f"{prog_name()}: error: {message}", file=sys.stderr)
    return 2


def parse(cls: type[T], argv: Optional[Sequence[str]] = None, description: str = "") -> T:
    """Parse ``argv`` into an instance of the dataclass ``cls``. Field docs come from the class
    docstring's ``name: text`` lines."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):  # subclasses document their own fields
        docs.update(_field_docs(klass.__doc__ or ""))
    parser = OneLineParser(prog=prog_name(), description=description)
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cast(Any, cls)):
        flag = "--" + f.name.replace("_", "-")
        kind = hints[f.name]
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:  # a programming error in an arguments class, not a user's
            raise TypeError(f"{cls.__name__}.{f.name}: a command-line field needs a default")
        doc = docs.get(f.name, "")
        help_text = doc if "default" in doc else f"{doc} (default: {default})"
        if kind is bool or kind == Optional[bool]:  # Optional: None when neither flag is given
            parser.add_argument(flag, action=argparse.BooleanOptionalAction, default=default, help=help_text)
        else:
            parser.add_argument(flag, type=_caster(kind), default=default, help=help_text)
    ns = parser.parse_args(argv)
    return cls(**vars(ns))


def _caster(kind: Any):
    args = typing.get_args(kind)
    if type(None) in args:  # Optional[X]
        inner = next(a for a in args if a is not type(None))

        def cast(text: str):
            return None if text.lower() == "none" else inner(text)
        return cast
    return kind


def _field_docs(doc: str) -> dict[str, str]:
    """``name: text`` lines of a docstring; a line indented deeper than the ``name:`` line before
    it, and not itself a ``name:`` line, continues that text (so long help wraps in the source)."""
    out: dict[str, str] = {}
    current, indent = None, 0
    for raw in doc.splitlines():
        line = raw.strip()
        depth = len(raw) - len(raw.lstrip())
        if ":" in line and line.split(":", 1)[0].isidentifier():
            name, text = line.split(":", 1)
            out[name] = text.strip()
            current, indent = name, depth
        elif current is not None and line and depth > indent:
            out[current] += " " + line
        else:
            current = None
    return out
