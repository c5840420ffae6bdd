"""FFCx's cache of compiled forms, made to survive a run killed while it compiled.

FFCx claims a form by creating ``NAME.c`` in its cache and marks it compiled with
``NAME.c.cached``; another process finding the first without the second waits for it
(10 seconds by default) and then fails with a ``TimeoutError``. A run killed between the
two (Ctrl-C twice, ``kill -9``, a job's time limit, ``MPI_Abort`` from another rank)
leaves the claim behind, and every later run that needs the same form fails, with the
same error, until the file is removed by hand. FFCx only clears the claim of a
compilation that fails with an exception.

:func:`recover_abandoned_compilations` wraps FFCx's lookup: a claim still unfinished
after the wait is taken as abandoned once its C file is :data:`ABANDONED_AFTER` seconds
old (a live compilation of this package's forms takes well under that), set aside as
``NAME.c.abandoned``, and the form compiled again, with one line on stderr.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from ffcx.codegeneration import jit

#: Seconds after which an unfinished claim on a form (its C file, written before the C
#: compiler starts) is taken as left by a killed run.
ABANDONED_AFTER = 300.0


def _claim_age(c_file: Path) -> float | None:
    try:
        return time.time() - c_file.stat().st_mtime
    except FileNotFoundError:
        return None


def recover_abandoned_compilations() -> None:
    """Install the wrapper on FFCx's cache lookup (idempotent)."""
    lookup = jit.get_cached_module
    if getattr(lookup, "recovers_abandoned", False):
        return

    def get_cached_module(module_name, object_names, cache_dir, timeout):
        while True:
            try:
                return lookup(module_name, object_names, cache_dir, timeout)
            except TimeoutError:
                c_file = Path(cache_dir) / f"{module_name}.c"
                age = _claim_age(c_file)
                if age is not None and age < ABANDONED_AFTER:
                    continue  # another process may still be compiling: wait again
                if age is not None:
                    try:
                        os.replace(c_file, c_file.with_suffix(".c.abandoned"))
                    except FileNotFoundError:
                        pass  # another process set it aside first
                    print(
                        f"nitsche-dolfinx: the form cache held {c_file.name}, left unfinished "
                        f"by a run killed {age / 60:.0f} min ago; compiling it again",
                        file=sys.stderr,
                    )
                # the claim is free now (or was finished meanwhile): look again
                return lookup(module_name, object_names, cache_dir, timeout)

    get_cached_module.recovers_abandoned = True
    jit.get_cached_module = get_cached_module
