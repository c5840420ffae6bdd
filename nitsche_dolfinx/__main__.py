"""``python -m nitsche_dolfinx run CONFIG.toml``: the same as the ``nitsche-dolfinx`` command."""

import sys

from .cli.main import main

sys.exit(main())
