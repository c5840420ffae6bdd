"""``python -m nitsche_dolfinx run CONFIG.toml``: the same as the ``nitsche-dolfinx`` command."""

import sys

from .cli.command import main

sys.exit(main())
