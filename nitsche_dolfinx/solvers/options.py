"""The PETSc options of one solver, under an options prefix of its own (docs/method.md
section 8).

PETSc reads a solver's options from its global options database when the solver is set
up (``setFromOptions``). A solver's options (its defaults, its linear solver's, the
user's) are put in the database under its prefix only for that reading, and taken out
after it: the database is global and bounded (512 entries in PETSc 3.18). The user's
viewers and monitors, which PETSc reads again at every solve, stay until the solver is
destroyed. Options that the user put in the database under the prefix themselves
(``-PREFIXsnes_monitor`` on the command line) win over all of these and are never taken
out.
"""

from __future__ import annotations

import contextlib
import itertools
from typing import Any

from petsc4py import PETSc

__all__ = ["PrefixedOptions", "unique_prefix"]

_counter = itertools.count()


def unique_prefix(stem: str = "nitsche") -> str:
    """A prefix that no other solver of this process has: ``stem_N_``."""
    return f"{stem}_{next(_counter)}_"


def _read_at_each_solve(key: str) -> bool:
    """Whether PETSc reads the option ``key`` again at each solve (viewers, monitors)."""
    return any(word in key for word in ("view", "converged_reason", "monitor"))


class PrefixedOptions:
    """The options of one solver: ``options`` (its own and the user's, merged), of which
    ``user`` are the user's, under ``prefix``.

    Args:
        prefix: The options prefix, e.g. ``"nitsche_0_"``.
        options: Every option of the solver, by key without the prefix (None: a switch).
        user: The keys among them that the user gave (their viewers and monitors stay in
            the database while the solver lives).
    """

    def __init__(self, prefix: str, options: dict[str, Any], user=()):
        self.prefix = prefix
        self.options = dict(options)
        self.user = set(user)
        self._kept: list[str] = []  # the user's monitors left in the database

    def given(self, key: str) -> bool:
        """Whether the database holds ``key`` under the prefix (set by the user there, or
        inserted by :meth:`reading`)."""
        return PETSc.Options().hasName(self.prefix + key)

    def string(self, key: str, default: str | None = None) -> str | None:
        """The database's value of ``key`` under the prefix, else the solver's option,
        else ``default``."""
        if self.given(key):
            return PETSc.Options().getString(self.prefix + key)
        value = self.options.get(key, default)
        return None if value is None else str(value)

    @contextlib.contextmanager
    def reading(self, options: dict[str, Any] | None = None):
        """Put ``options`` (default: all of the solver's) in the database for the block,
        except those the database already holds, and take them out after it, but for
        the user's viewers and monitors. Yields the names inserted."""
        database = PETSc.Options()
        inserted = []
        for key, value in (self.options if options is None else options).items():
            name = self.prefix + key
            if database.hasName(name):
                continue
            database[name] = "" if value is None else value
            inserted.append(name)
        try:
            yield inserted
        finally:
            for name in inserted:
                key = name[len(self.prefix) :]
                if key in self.user and _read_at_each_solve(key):
                    self._kept.append(name)
                else:
                    database.delValue(name)

    @contextlib.contextmanager
    def replaced(self, key: str, value: str, apply):
        """Give ``key`` the value ``value`` for the block: ``apply()`` (the solver's
        ``setFromOptions``) reads it, and again the previous value after the block (the
        user's in the database, else the solver's current one ``self.string(key)``)."""
        database = PETSc.Options()
        name = self.prefix + key
        kept = database.hasName(name)  # set in the database by the user
        previous = database.getString(name) if kept else self.string(key)
        database[name] = value
        apply()
        try:
            yield
        finally:
            database[name] = previous
            apply()
            if not kept:
                database.delValue(name)

    def destroy(self) -> None:
        """Take the user's viewers and monitors out of the database."""
        for name in self._kept:
            PETSc.Options().delValue(name)
        self._kept = []
