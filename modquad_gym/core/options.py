"""Command-line option types shared by ``modquad`` and the benchmarks: a bad number is an
argparse error (exit 2, naming the option) while the command line is parsed, before any work.

Numbers are strict, one rule for every text door (:func:`parse_integer`, :func:`parse_real`;
task files read theirs by the same patterns): ASCII decimal digits only, so Python's digit
separators (``1_0``), other scripts' digits (``١٢``, ``²``), hexadecimal and non-finite values are
not numbers here.
"""

from __future__ import annotations

import argparse
import math
import numbers
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

__all__ = [
    "MAX_COUNT",
    "MAX_SEED",
    "DefaultsHelpFormatter",
    "OneLineParser",
    "check_option",
    "int_option",
    "nonempty_option",
    "parse_integer",
    "parse_real",
    "path_option",
    "real_option",
    "seed_option",
    "text_parser",
    "text_words",
]

MAX_COUNT = 1_000_000
"""Largest count (tasks, seeds, structures, steps, ...) an option accepts by default."""

MAX_SEED = 2**63 - 1
"""Largest random seed (NumPy takes any non-negative integer; this keeps seeds printable)."""

INTEGER_PATTERN = r"[+-]?[0-9]+"
"""An integer as text: ASCII digits (``\\d`` and ``int()`` would read any script's digits)."""

DECIMAL_PATTERN = r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
"""A real number as text: plain decimal notation in ASCII digits (``float()`` would also read
``1_0``, ``١٢`` and ``inf``)."""

NUMBER_PATTERN = DECIMAL_PATTERN + r"|[+-]?(?:nan|inf|infinity)"
"""A decimal or a non-finite word (case aside): what a task file's cell or an ``--option``
value may be, read so that the value's own check refuses nan and inf by name."""

_INT = re.compile(INTEGER_PATTERN)
_REAL = re.compile(DECIMAL_PATTERN)
_NUMBER = re.compile(NUMBER_PATTERN, re.I)


def parse_integer(text: str) -> int:
    """``text`` (surrounding blanks aside) as an int by the one rule (module docstring), else a
    ValueError ``expected an integer, got '...'``."""
    if not isinstance(text, str) or not _INT.fullmatch(text.strip()):
        raise ValueError(f"expected an integer, got {text!r:.60}")
    return int(text)


def parse_real(text: str) -> float:
    """``text`` (surrounding blanks aside) as a finite float by the one rule (module
    docstring), else a ValueError ``expected a finite number, got '...'``."""
    if not isinstance(text, str) or not _REAL.fullmatch(text.strip()):
        raise ValueError(f"expected a finite number, got {text!r:.60}")
    value = float(text)
    if not math.isfinite(value):  # 1e999
        raise ValueError(f"expected a finite number, got {text!r:.60}")
    return value


def int_option(low: int, high: int = MAX_COUNT):
    """An argparse ``type`` for an integer within [low, high]."""

    def parse(text: str) -> int:
        try:
            value = parse_integer(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be in {low}..{high}, got {value}")
        return value

    parse.__name__ = "integer"  # argparse names the type in its messages
    parse.is_integer = True  # what check_option checks a Python caller's value against
    return parse


def seed_option(text: str) -> int:
    """An argparse ``type`` for a random seed: an integer in 0..2**63-1."""
    return int_option(0, MAX_SEED)(text)


seed_option.is_integer = True


def check_option(flag: str, value: object, kind=None, many: bool = False) -> None:
    """A Python caller's ``value`` of the option ``flag`` checked as the command line checks it:
    a list where ``many`` (``nargs``, ``append``), an integer where ``kind`` is
    :func:`int_option`'s or :func:`seed_option`, a path that is not empty where it is
    :func:`path_option`, text that is not empty where it is :func:`nonempty_option`, in the
    command line's words (ValueError ``FLAG: ...``). None (the default) passes."""
    if value is None:
        return
    if many:
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
            raise ValueError(f"{flag}: a list of values, got {value!r}")
        for v in value:
            check_option(flag, v, kind)
        return
    if getattr(kind, "is_path", False):
        if isinstance(value, str) and not value:
            raise ValueError(f"{flag}: {EMPTY_PATH}")
        return
    if getattr(kind, "is_text", False):
        if isinstance(value, str) and not value.strip():
            raise ValueError(f"{flag}: {EMPTY_VALUE.format(value=value)}")
        return
    if not getattr(kind, "is_integer", False):
        return
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{flag}: expected an integer, got {value!r}")
    try:
        kind(str(int(value)))
    except argparse.ArgumentTypeError as exc:
        raise ValueError(f"{flag}: {exc}") from None


def path_option(text: str) -> Path:
    """An argparse ``type`` for a file or folder path: an empty one is refused (``Path("")`` is
    the working folder, which the user did not name)."""
    if not text:
        raise argparse.ArgumentTypeError(EMPTY_PATH)
    return Path(text)


path_option.__name__ = "path"
path_option.is_path = True  # what check_option checks a Python caller's value against

EMPTY_PATH = "an empty path (give a file or folder name; . is the working folder)"
"""What an empty path option is told (:func:`path_option`, :func:`check_option`)."""


def nonempty_option(text: str) -> str:
    """An argparse ``type`` for a text option (a name, an address, JSON): an empty value is
    refused, not taken for the option left out (``--tier ''`` is not the default tier)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(EMPTY_VALUE.format(value=text))
    return text


nonempty_option.__name__ = "text"
nonempty_option.is_text = True  # what check_option checks a Python caller's value against

EMPTY_VALUE = "an empty value ({value!r}): give one, or leave the option out for its default"
"""What an empty text option is told (:func:`nonempty_option`, :func:`check_option`)."""


def real_option(text: str) -> float:
    """An argparse ``type`` for a finite real number (range checks stay with the command, which
    names the bounds)."""
    try:
        return parse_real(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


real_option.__name__ = "number"


def _bool(text: str) -> bool:
    low = text.lower()
    if low in ("1", "true", "yes", "on"):
        return True
    if low in ("0", "false", "no", "off"):
        return False
    raise ValueError(text)


def _float(text: str) -> float:
    """An ``--option`` number (:data:`NUMBER_PATTERN`: nan is read, for the option's check to
    refuse it by name), else a ValueError."""
    if not _NUMBER.fullmatch(text.strip()):
        raise ValueError(f"expected a number, got {text!r:.60}")
    return float(text)


def _floats(text: str) -> tuple[float, ...]:
    return tuple(_float(part) for part in text.split(",")) if text else ()


_PARSERS = {"int": parse_integer, "float": _float, "bool": _bool, "tuple[float,...]": _floats}
"""How a command line writes a value of each type (``--option KEY=VALUE``)."""

_WORDS = {
    "int": "an integer",
    "float": "a number",
    "bool": "a boolean (true/false)",
    "tuple[float,...]": "comma-separated numbers",
}
"""What an error says each type of :data:`_PARSERS` takes."""


def _kind(annotation: object) -> str:
    if isinstance(annotation, type):
        return annotation.__name__
    return str(annotation).replace(" ", "")


def text_parser(annotation: object) -> Callable[[str], Any] | None:
    """The function reading a value of type ``annotation`` (``int``, ``float``, ``bool``,
    ``tuple[float, ...]``, each optionally ``| None``, then written ``none``) from a command
    line's text (a ValueError for text it cannot read); None for other types (Python only)."""
    kind = _kind(annotation)
    base = kind.removesuffix("|None")
    if base not in _PARSERS:
        return None
    parse = _PARSERS[base]
    if base == kind:
        return parse
    return lambda text: None if text.lower() == "none" else parse(text)


def text_words(annotation: object, none: bool = True) -> str:
    """What a command line writes for a value of type ``annotation``, in words: ``a boolean
    (true/false)``, ``an integer or none`` (without ``or none`` where ``none`` is refused)."""
    kind = _kind(annotation)
    base = kind.removesuffix("|None")
    return _WORDS.get(base, base) + (" or none" if base != kind and none else "")


class DefaultsHelpFormatter(argparse.HelpFormatter):
    """Help that states each option's default once: ``(default: X)`` is added where the help
    does not already speak of its default, and never for a default that says nothing (None,
    False, an empty list) (argparse's ``ArgumentDefaultsHelpFormatter`` adds it to every option:
    ``(default: the tier's) (default: None)``)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        silent = default is None or default is False or default == [] or default == ()
        if (
            "default" in text.lower()
            or silent
            or default is argparse.SUPPRESS
            or not (action.option_strings or action.nargs in (argparse.OPTIONAL, "*"))
        ):
            return text
        return f"{text} (default: %(default)s)"


class OneLineParser(argparse.ArgumentParser):
    """The parser of every command (``modquad`` and its commands, ``train.py``, the scoring
    and benchmark scripts): an option it refuses is one line, ``PROG: error: MESSAGE``, exit 2,
    as every refusal after parsing is (argparse prints its usage block first; ``PROG --help``
    shows it). A command's subparsers are of this class too (argparse makes them of their
    parent's)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {' '.join(message.splitlines())}\n")
