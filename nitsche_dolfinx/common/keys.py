"""How a key of a run description is described: its kind, default and meaning.

The registries of the things a configuration names (schemes in
:mod:`~nitsche_dolfinx.steppers.schemes`, obstacles in :mod:`~nitsche_dolfinx.physics.obstacles`,
mesh
generators in :mod:`~nitsche_dolfinx.config.mesh_generators`) and the table of run parameters
(:mod:`~nitsche_dolfinx.config.parameter_table`) describe their keys with :class:`Key`; the TOML
schema (:mod:`~nitsche_dolfinx.config.schema`), the demos' flags and ``docs/parameters.md`` are
made from them. This module imports nothing of the package: every layer may use it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = [
    "KINDS",
    "LARGEST",
    "REQUIRED",
    "SHOWN_LENGTH",
    "Key",
    "cut",
    "is_integer",
    "is_number",
    "is_plain",
    "shown",
    "toml_text",
]

#: The largest magnitude of a number of a configuration that the front end lets through
#: without a check of its own (coordinates, lengths, loads): the forms multiply up to
#: three such numbers (a stress squared times a length, say), and 1e100 cubed is still a
#: double. The run parameters have their own ranges (:mod:`~nitsche_dolfinx.common.parameters`).
LARGEST = 1e100
#: The longest value a message quotes whole: a longer one is cut to its start and its
#: length (a text of a megabyte is named, not echoed).
SHOWN_LENGTH = 120


class _Required:
    def __repr__(self):
        return "required"


#: The default of a key that must be given.
REQUIRED = _Required()


def is_number(value) -> bool:
    """A real number: an int or a float (numpy's too), not a bool and not a string."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def is_integer(value) -> bool:
    """An integer (numpy's too), not a bool."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _is_vector(value) -> bool:
    return is_number(value) or (isinstance(value, list) and all(is_number(x) for x in value))


#: kind -> (how it is named in messages, the check of a value's type).
KINDS: dict[str, tuple[str, Callable[[object], bool]]] = {
    "string": ("a string", lambda v: isinstance(v, str)),
    "integer": ("an integer", is_integer),
    "number": ("a number", is_number),
    "step": ('a number or "auto"', lambda v: v == "auto" or is_number(v)),
    "boolean": ("true or false", lambda v: isinstance(v, bool)),
    "vector": ("a number or a list of numbers", _is_vector),
    "tag pair": (
        "a list of two integer tags",
        lambda v: isinstance(v, list) and len(v) == 2 and all(is_integer(x) for x in v),
    ),
    "strings": (
        "a list of strings",
        lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v),
    ),
    # checked in depth by nitsche_dolfinx.physics.valueforms
    "value in time": (
        "a vector (of numbers or expressions of x, y, z, t), a table [[t, value...], ...] "
        "or a profile {profile = ...}",
        lambda v: is_number(v) or isinstance(v, (str, list, dict)),
    ),
    "scalar in time": (
        "a number, an expression of t, a table [[t, value], ...] or a profile {profile = ...}",
        lambda v: is_number(v) or isinstance(v, (str, list, dict)),
    ),
    "value in x": (
        "a vector (of numbers or expressions of x, y, z) or {constant, gradient, hessian}",
        lambda v: is_number(v) or isinstance(v, (str, list, dict)),
    ),
    # its keys: nitsche_dolfinx.config.schema.FACET_SELECTORS
    "selector": ("an inline table { key = value, ... }", lambda v: isinstance(v, dict)),
    # [petsc]: any flat table of options
    "options": ("a table of options", lambda v: isinstance(v, dict)),
}


@dataclass(frozen=True)
class Key:
    """One key: its kind (a key of :data:`KINDS`), its default (:data:`REQUIRED`, None for
    "not set", or a value), what it means and the choices of a string key.

    ``check`` (a value -> bool) and ``requirement`` (what a value must be, after "must
    be") are the range of a key that no object of the library checks itself (the keys
    of the mesh generators). The front end refuses numbers that are not finite or of
    magnitude above :data:`LARGEST`, and strings not among the choices, unless
    ``checked_by_library``: the run parameters, whose objects check their values in
    their own words (a TOML file and the API then give the same message).
    """

    kind: str
    default: object
    meaning: str
    choices: tuple = ()
    shown_default: str | None = None  # the default in words, when not a plain value
    check: Callable[[object], bool] | None = None
    requirement: str = ""
    checked_by_library: bool = False

    @property
    def required(self) -> bool:
        """Whether the key has no default (:data:`REQUIRED`)."""
        return self.default is REQUIRED

    def default_text(self) -> str:
        """The default as TOML writes it (or in words)."""
        if self.shown_default is not None:
            return self.shown_default
        if self.required:
            return "required"
        return "none" if self.default is None else toml_text(self.default)

    def fits(self, value) -> bool:
        """Whether ``value`` is of the key's kind."""
        return KINDS[self.kind][1](value)

    def problem(self, value) -> str | None:
        """What is wrong with ``value``, a value of the key's kind (``"must be ..."`` or
        ``"unknown; ..."``), or None: its magnitude, its choices, its range."""
        if self.checked_by_library:
            return None
        if self.kind in ("number", "vector"):
            numbers = value if isinstance(value, list) else [value]
            if not all(math.isfinite(x) for x in numbers):
                return "must be finite"
            if any(abs(x) > LARGEST for x in numbers):
                return f"must be at most {LARGEST:g} in magnitude"
        if self.choices and value not in self.choices:
            return f"unknown; choose one of {', '.join(self.choices)}"
        if self.check is not None and not self.check(value):
            return f"must be {self.requirement}"
        return None


def toml_text(value) -> str:
    """``value`` as TOML writes it."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_text(x) for x in value) + "]"
    return repr(value)


def cut(text: str, length: int = SHOWN_LENGTH) -> str:
    """``text``, or when longer than ``length`` its start and its length in characters."""
    if len(text) <= length:
        return text
    return f"{text[: length - 40]}... ({len(text)} characters)"


def shown(value) -> str:
    """``value`` as a message quotes it: its repr on one line (an array as a list), a long
    text in it cut to its start and its length, and the whole cut to :data:`SHOWN_LENGTH`
    characters (:func:`cut`)."""
    return cut(_quoted(value))


def _quoted(value) -> str:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, str) and len(value) > SHOWN_LENGTH // 2:
        return f"{value[:40]!r}... (a text of {len(value)} characters)"
    if isinstance(value, list):
        return "[" + ", ".join(_quoted(item) for item in value) + "]"
    return repr(value)


def is_plain(value) -> bool:
    """Whether ``value`` is data a user writes (a number, a string, a boolean, None, or
    lists, tuples and tables of them), not an object of the library or a function, whose
    repr a message of a configuration does not show."""
    if value is None or isinstance(value, (str, bool, np.bool_)) or is_number(value):
        return True
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "biuf"
    if isinstance(value, (list, tuple)):
        return all(is_plain(item) for item in value)
    if isinstance(value, dict):
        return all(isinstance(key, str) and is_plain(item) for key, item in value.items())
    return False
