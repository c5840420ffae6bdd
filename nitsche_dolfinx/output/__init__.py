"""What a run measures and writes: energies and contact forces (`diagnostics`), the momentum
and the centre of mass (`mass_moments`), probes (`probes`), the history's rows and columns
(`history`), the fields of solution.xdmf (`fields`, `series`, `writers`), checkpoints
(`checkpoint`), the progress on the terminal (`progress`).
"""

from .checkpoint import (
    CHECKPOINT_FILE,
    CheckpointError,
    SavedState,
    has_checkpoint,
    load_state,
    match_points,
    save_state,
)
from .diagnostics import Diagnostics, Penetration
from .fields import ContactFields, LevelRefresh, OnBoundary, body_fields
from .history import (
    DAMPING_COLUMNS,
    FINITE_COLUMNS,
    FRICTION_HISTORY_COLUMNS,
    HISTORY_COLUMNS,
    OBSTACLE_COLUMNS,
    PAIRING_COLUMNS,
    STATE_COLUMNS,
    WORK_COLUMNS,
    History,
    angular_momentum_columns,
    body_columns,
    contact_columns,
    momentum_columns,
)
from .mass_moments import MassMoments, assembled_matrix
from .probes import BoundaryAverage, BoundaryField, PointValue, assemble_global
from .progress import Progress
from .series import continue_solution, read_solution
from .writers import HistoryWriter, SolutionWriter, ensure_directory, read_history

__all__ = [
    "BoundaryAverage",
    "BoundaryField",
    "CHECKPOINT_FILE",
    "CheckpointError",
    "ContactFields",
    "DAMPING_COLUMNS",
    "Diagnostics",
    "FINITE_COLUMNS",
    "FRICTION_HISTORY_COLUMNS",
    "HISTORY_COLUMNS",
    "History",
    "HistoryWriter",
    "LevelRefresh",
    "MassMoments",
    "OBSTACLE_COLUMNS",
    "OnBoundary",
    "PAIRING_COLUMNS",
    "Penetration",
    "PointValue",
    "Progress",
    "STATE_COLUMNS",
    "SavedState",
    "SolutionWriter",
    "WORK_COLUMNS",
    "angular_momentum_columns",
    "assemble_global",
    "assembled_matrix",
    "body_columns",
    "body_fields",
    "contact_columns",
    "continue_solution",
    "ensure_directory",
    "has_checkpoint",
    "load_state",
    "match_points",
    "momentum_columns",
    "read_history",
    "read_solution",
    "save_state",
]
