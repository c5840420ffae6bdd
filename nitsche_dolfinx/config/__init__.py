"""TOML run files: reading and checking them (`reader`, `schema`), the simulation they describe
(`builder`), the meshes they can generate (`mesh_generators`), and every run parameter's API
keyword, TOML key and demo flag in one table (`parameter_table`).
"""

from .builder import build_simulation
from .parameter_table import DEMO_DEFAULT, OWNERS, PARAMETERS, by_flag, by_name, markdown
from .reader import ConfigError, history_columns, load_config, output_parameters, reported_at
from .schema import FACET_SELECTORS, SCHEMA, describe

__all__ = [
    "ConfigError",
    "DEMO_DEFAULT",
    "FACET_SELECTORS",
    "OWNERS",
    "PARAMETERS",
    "SCHEMA",
    "build_simulation",
    "by_flag",
    "by_name",
    "describe",
    "history_columns",
    "load_config",
    "markdown",
    "output_parameters",
    "reported_at",
]
