"""The run driver: a :class:`ContactProblem <nitsche_dolfinx.model.problem.ContactProblem>`
marched in time, with its history, fields, checkpoints, restarts and signals.

:class:`Simulation` builds the stepper of the problem's method and scheme
(:func:`~nitsche_dolfinx.steppers.factory.make_stepper`) and runs it; everything around
the steps is the same for every method::

    simulation = Simulation(problem, HybridScheme(), dt=0.015, t_end=6.0)
    history = simulation.run(out="out/bar", output_every=10, checkpoint_every=100)
    history["energy"], history.energy_drift()
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import Any

from .common.agreement import FailureChannel
from .common.collective import collect_garbage_together, garbage_collected_together
from .common.parameters import OutputParameters, SolverParameters, TimeStepping, require
from .common.signals import RunInterrupted, StopSignals
from .contact.coercivity import constant_value
from .model.problem import ContactProblem
from .output.checkpoint import CheckpointError, SavedState, load_state, save_state
from .output.history import HISTORY_COLUMNS, History
from .output.progress import Progress
from .output.series import continue_solution
from .output.writers import HistoryWriter, SolutionWriter, ensure_directory
from .solvers.solver import SolverError
from .steppers.base import Stepper
from .steppers.factory import make_stepper, step_linear_solver
from .steppers.schemes import TimeScheme

__all__ = ["Simulation"]


def _from_stepper(name: str, doc: str) -> property:
    return property(lambda self: getattr(self.stepper, name), doc=doc)


class Simulation:
    """March a :class:`~nitsche_dolfinx.model.problem.ContactProblem` in time.

    Args:
        problem: The problem; its ``method`` chooses the stepper.
        scheme: The time scheme (the mixed method takes Crank-Nicolson only).
        dt: Time step tau (> 0).
        t_end: Final time T (>= dt), reached exactly: when T is not a multiple of tau,
            the last step is shorter.
        petsc_options: PETSc options for the step's SNES
            (see :class:`~nitsche_dolfinx.solvers.solver.SNESSolver`).
        progress: Show the progress on rank 0: one bar on a terminal (with tqdm), else one
            line per step (:class:`~nitsche_dolfinx.output.progress.Progress`).
        reuse_jacobian: Assemble the constant bulk Jacobian once and re-factorise only
            when the contact part of the Jacobian changes (the default); False
            re-assembles and re-factorises at every Newton iteration.
        preconditioner_lag: When > 0, keep the last factorised Jacobian as the
            preconditioner of GMRES until a linear solve needs more than this many
            iterations (see :class:`~nitsche_dolfinx.solvers.solver.SNESSolver`).
        guard_friction: With friction, solve each step's Coulomb law by semismooth
            Newton guarded by a reference state (the default; False: plain semismooth
            Newton on [P_t]_r); see :class:`~nitsche_dolfinx.steppers.friction.GuardedNewton`
            and docs/method.md section 8.
        linear_solver: A preset of :mod:`nitsche_dolfinx.solvers.linear_solvers` (``"auto"``,
            ``"lu"``, ``"lu-lagged"``, ``"cg-jacobi"``, ``"cg-gamg"``, ``"gmres-gamg"``);
            ``petsc_options`` win over its options, and it sets ``preconditioner_lag``.
            ``"auto"`` (the default) chooses from the problem and ``dt`` (docs/method.md
            section 8), unless ``petsc_options`` name a ``ksp_type`` or ``pc_type`` or
            ``preconditioner_lag`` is given: the solver is then the user's. None: the
            solver's defaults (lu).
        max_step_cuts: In :meth:`run`, a step whose Newton solve fails (with full steps,
            then with a line search) is replaced by two half steps, and those again,
            down to tau / 2^max_step_cuts; then the run stops with the last converged
            state saved (docs/method.md section 8). 0: no cutting.

    The state of the current time level is ``u``, ``v``, ``a``, ``t`` and
    ``step_index``; ``stepper`` is the object that makes the steps.
    """

    problem = _from_stepper("problem", "The problem.")
    scheme = _from_stepper("scheme", "The time scheme.")
    comm = _from_stepper("comm", "The communicator of the mesh.")
    dt = _from_stepper("dt", "The (nominal) time step tau.")
    t_end = _from_stepper("t_end", "The final time T.")
    num_steps = _from_stepper("num_steps", "The number of nominal steps of a run to t_end.")
    finished = _from_stepper("finished", "Whether t_end is reached.")
    u = _from_stepper("u", "The displacement u^n (a Function).")
    v = _from_stepper("v", "The velocity v^n (a Function).")
    a = _from_stepper("a", "The acceleration a^n (a Function).")
    t = _from_stepper("t", "The current time t^n.")
    step_index = _from_stepper("step_index", "The number n of steps made.")
    newton_iterations = _from_stepper("newton_iterations", "Newton iterations of the last step.")
    solver = _from_stepper("solver", "The step's SNESSolver.")

    def __init__(
        self,
        problem: ContactProblem,
        scheme: TimeScheme,
        dt: float,
        t_end: float,
        petsc_options: dict[str, Any] | None = None,
        progress: bool = False,
        reuse_jacobian: bool = True,
        preconditioner_lag: int = 0,
        guard_friction: bool = True,
        linear_solver: str | None = "auto",
        max_step_cuts: int = 5,
    ):
        time_stepping = TimeStepping(dt, t_end, max_step_cuts)
        require(
            scheme.explicit or not time_stepping.automatic, "dt", dt,
            "an automatic step is the verlet scheme's (its stable step): give tau",
        )  # fmt: skip
        SolverParameters(reuse_jacobian, preconditioner_lag, guard_friction)
        # the set-up leaves reference cycles (UFL, forms) that hold PETSc vectors
        with garbage_collected_together(problem.mesh.comm):
            self.max_step_cuts = int(max_step_cuts)
            solver = step_linear_solver(
                problem, scheme, dt, linear_solver, petsc_options, preconditioner_lag
            )
            #: The linear solver in words, for summaries.
            self.solver_description = solver.description
            self.stepper: Stepper = make_stepper(
                problem, scheme, time_stepping, petsc_options, solver, reuse_jacobian,
                guard_friction,
            )  # fmt: skip
        self.progress = progress
        self._probes: dict[str, Callable[[], float]] = {}

    @property
    def dofs(self) -> int:
        """The global number of degrees of freedom of the displacement."""
        V = self.problem.V
        return V.dofmap.index_map.size_global * V.dofmap.index_map_bs

    def add_probe(self, name: str, probe: Callable[[], float]) -> None:
        """Add a history column computed by ``probe()`` at every time level (the same
        number on every rank): a :class:`~nitsche_dolfinx.output.probes.BoundaryAverage`
        (a mean over a boundary part or the body), a
        :class:`~nitsche_dolfinx.output.probes.PointValue` (a Function at a point), or any
        function. Name it in ``run(columns=...)`` to write it."""
        self._probes[name] = probe

    def contact_pressure(self):
        """The contact pressure of the first contact term (the first obstacle added, or the
        first half of a contact pair) on its Gamma_C, a UFL expression of the current
        state: lambda_h of docs/method.md section 2, or the mixed multiplier."""
        return self.stepper.contact_pressure()

    def state(self, columns=None) -> dict[str, float]:
        """The diagnostics of the current time level and the probes, the same on every rank;
        the optional diagnostics (penetration, momentum, centre of mass, the totals of each
        contact) only when ``columns`` name them (None: all)."""
        values = self.stepper.state(columns)
        for name, probe in self._probes.items():
            values[name] = probe()
        return values

    def step(self, t_new: float | None = None) -> int:
        """Advance one time step, to the next nominal level or to ``t_new``; returns the
        Newton iterations (no step cutting: that is :meth:`run`'s)."""
        return self.stepper.step(t_new)

    def output_fields(self) -> dict:
        """The fields of ``solution.xdmf``: ``{name: (function or expression, shape)}``."""
        return self.stepper.output_fields()

    # -- a run ---------------------------------------------------------------------------

    def run(
        self,
        out: str | None = None,
        columns=HISTORY_COLUMNS,
        callback: Callable[[Simulation], None] | None = None,
        output_every: int = 0,
        checkpoint_every: int = 0,
        restart: str | bool | None = None,
    ) -> History:
        """Run to t_end, or until a solver failure or a signal stops it cleanly.

        Args:
            out: Output folder for ``history.csv`` (and ``solution.xdmf`` when
                ``output_every > 0``, and the checkpoints in ``out/checkpoint``);
                nothing is written when omitted.
            columns: History columns: names of :meth:`state` entries.
            callback: Called as ``callback(simulation)`` after every step.
            output_every: Write the XDMF fields every this many steps (0: never).
            checkpoint_every: Write a checkpoint every this many steps and at the end
                (0: only when the run stops early). Needs ``out``.
            restart: Continue from a checkpoint: its folder, or True for
                ``out/checkpoint``. The history keeps its rows up to the checkpoint
                and continues; the XDMF series is appended to (see
                :func:`~nitsche_dolfinx.output.series.continue_solution`).

        Returns:
            The :class:`~nitsche_dolfinx.output.history.History`, one row of :meth:`state`
            values per time level (after a restart, the rows kept from
            ``history.csv`` come first).

        Raises:
            SolverError: A step's Newton solve failed, also on the cut steps down to
                tau / 2^max_step_cuts. The history and the fields stay readable up to
                the last converged step, and that state is saved in ``out/checkpoint``
                (``error.checkpoint``, a :class:`~nitsche_dolfinx.output.checkpoint.SavedState`);
                a restart may change dt, gamma0 and the solver options.
            RunInterrupted: SIGINT or SIGTERM arrived (on any rank): every rank stops
                after the same step, which is saved the same way.
            CheckpointError: The checkpoint to restart from is missing or does not fit.
        """
        output = OutputParameters(output_every, checkpoint_every)
        self._check_columns(columns)
        with garbage_collected_together(self.comm):
            return self._run(_Run(self, out, list(columns), output), restart, callback)

    def _run(self, run: _Run, restart, callback) -> History:
        run.open(restart)
        failures = FailureChannel(self.comm)
        collective_exit = False
        try:
            with StopSignals() as signals:
                run.march(signals, callback)
            collective_exit = True
        except (SolverError, RunInterrupted, CheckpointError):
            collective_exit = True  # raised on every rank alike
            raise
        except BaseException:
            # closing the XDMF file is collective: if the other ranks did not fail, they
            # wait elsewhere, and the file is left to the end of the process
            collective_exit = failures.every_rank_failed()
            raise
        finally:
            run.close(collective_exit)
            if collective_exit:
                failures.free()
        return run.history

    def _check_columns(self, columns) -> None:
        """Refuse history columns that are not names of :meth:`state` (before the run)."""
        require(
            not isinstance(columns, str) and len(columns) > 0,
            "columns",
            columns,
            "must be a list of column names, at least one",
        )
        known = list(self.state())
        for name in columns:
            require(
                name in known, "columns", name,
                f"not a column of this run (it has {', '.join(known)})",
            )  # fmt: skip

    # -- checkpoints ---------------------------------------------------------------------

    def save_checkpoint(self, folder: str, columns=None) -> SavedState:
        """Save the current time level in the checkpoint folder ``folder`` (collective;
        see :func:`~nitsche_dolfinx.output.checkpoint.save_state`)."""
        return save_state(self.stepper, folder, columns)

    def load_checkpoint(self, folder: str, columns=None) -> SavedState:
        """Restore the time level saved in ``folder`` (collective; any partition of the
        same mesh reloads it, see :func:`~nitsche_dolfinx.output.checkpoint.load_state`)."""
        return load_state(self.stepper, folder, columns)


class _Run:
    """One call of :meth:`Simulation.run`: its files, its checkpoints and its loop."""

    def __init__(self, simulation: Simulation, out, columns: list[str], output: OutputParameters):
        if output.checkpoint_every and out is None:
            raise ValueError("checkpoint_every needs an output folder (out)")
        self.simulation, self.out, self.columns, self.output = simulation, out, columns, output
        self.comm = simulation.comm
        self.checkpoints = os.path.join(out, "checkpoint") if out is not None else None
        self.last_saved: SavedState | None = None  # the checkpoint of the current step
        self.restarted = False
        self.warned_cut = False  # the note on the first cut step is printed
        self.history = History()
        self.writer: HistoryWriter | None = None
        self.fields: SolutionWriter | None = None
        self.progress: Progress | None = None

    def open(self, restart) -> None:
        """Load the checkpoint to restart from, if any, and open the output files."""
        sim = self.simulation
        if restart is True and self.checkpoints is None:
            raise ValueError("restart=True needs an output folder (out), or give the folder")
        if self.out is not None:
            ensure_directory(self.out, self.comm)
        source = None
        if restart not in (None, False):
            source = self.checkpoints if restart is True else str(restart)
            saved = sim.load_checkpoint(source, self.columns)
            self.restarted = True
            if source == self.checkpoints:
                self.last_saved = saved
            if sim.progress and self.comm.rank == 0:
                print(f"restart: from {source}, step {saved.step}, t = {saved.t:.6g}", flush=True)
            if saved.changes:
                self.log_changes(saved)
        self.progress = Progress(sim.progress, self.comm, sim.t, sim.t_end)
        stable = getattr(sim.stepper, "stable_dt", None)
        if stable is not None:  # an explicit scheme: the step it runs against its limit
            self.progress.write(
                f"{sim.scheme.describe()}: stable dt = {stable:.6g} (estimated), dt = {sim.dt:.6g} "
                f"({sim.dt / stable:.3g} of it)"
            )
            ratio = sim.stepper.coercivity
            if ratio >= 1.0 and self.comm.rank == 0:  # even when quiet
                gamma0 = constant_value(sim.problem.gamma0)
                self.progress.message(
                    f"note: gamma0 = {gamma0:.6g} is beyond the coercivity bound of this mesh "
                    f"for Theta > 0 (cell-wise ratio {ratio:.3g} >= 1; gamma0 below "
                    f"{gamma0 / ratio:.3g} keeps A_Thgamma coercive): the explicit steps may "
                    "grow whatever dt (docs/method.md section 12)",
                    file=sys.stderr,
                )
        if self.out is None:
            return
        path = os.path.join(self.out, "history.csv")
        resume_at = sim.t if self.restarted else None
        # a restart into another folder continues the history beside the checkpoint
        beside = None
        if self.restarted and source != self.checkpoints:
            beside = os.path.join(os.path.dirname(os.path.abspath(source)), "history.csv")
        self.writer = HistoryWriter(path, self.columns, self.comm, resume_at, beside)
        self.history.extend(self.writer.previous_rows)
        if self.output.output_every > 0:
            self.fields = self._solution_writer()

    def log_changes(self, saved: SavedState) -> None:
        """Say what a restart changed (dt, gamma0), and add it to ``out/restarts.log``."""
        changes = ", ".join(
            f"{key} {old!r} -> {new!r}" for key, (old, new) in saved.changes.items()
        )
        line = f"restart at step {saved.step} (t = {saved.t!r}) from {saved.folder}: {changes}"
        if self.comm.rank != 0:
            return
        if self.simulation.progress:
            print(line, flush=True)
        if self.out is not None:
            with open(os.path.join(self.out, "restarts.log"), "a") as log:
                log.write(line + "\n")

    def _solution_writer(self) -> SolutionWriter:
        sim = self.simulation
        path, append = os.path.join(self.out, "solution.xdmf"), False
        if self.restarted:
            path, append = continue_solution(path, sim.t, sim.step_index, self.comm)
            moved = not append and os.path.basename(path) != "solution.xdmf"
            if moved and sim.progress and self.comm.rank == 0:
                print(
                    f"restart: solution.xdmf holds fields after t = {sim.t:.6g} (or cannot be "
                    f"read); the fields from step {sim.step_index} on go to {path}",
                    flush=True,
                )
        return SolutionWriter(path, sim.problem.mesh, sim.output_fields(), append=append)

    def march(self, signals: StopSignals, callback) -> None:
        """Record the first level, then step to t_end; checkpoint as asked, and on a stop."""
        sim, every = self.simulation, self.output.checkpoint_every
        if not self.restarted or self.writer is None or not self.writer.previous_rows:
            # a restarted level is already written, unless the history starts there
            self.record(write=not self.restarted or self.writer is not None)
        while not sim.finished:
            try:
                self.advance(sim.stepper.next_time(), 0, signals, callback)
            except SolverError as error:
                error.checkpoint = self.save_on_stop()
                raise
        if every and (self.last_saved is None or self.last_saved.step != sim.step_index):
            sim.save_checkpoint(self.checkpoints, self.columns)

    def advance(self, t_target: float, cuts: int, signals: StopSignals, callback) -> None:
        """Step to ``t_target``: in one step, or, if Newton fails, in two halves (each cut
        again as needed, ``cuts`` times so far) down to tau / 2^max_step_cuts."""
        sim = self.simulation
        try:
            sim.stepper.step(t_target, cuts)
        except SolverError as error:
            if not error.cut_may_help:
                raise
            if cuts >= sim.max_step_cuts:
                hint = sim.problem.solver_hint()
                if hint:
                    error.add_hint(f"also with steps of dt/{2**cuts:g}; {hint}")
                raise
            failed = error
        else:
            self.after_step(signals, callback)
            return
        self.progress.write(
            f"step to t = {t_target:.6g} failed ({failed.reason_name}): two steps of "
            f"{(t_target - sim.t) / 2:.4g} instead"
        )
        if not self.warned_cut and self.comm.rank == 0:  # once per run, even when quiet
            hint = sim.problem.solver_hint()
            hint = f"; if this recurs, {hint}" if hint else ""
            self.progress.message(
                f"note: the step to t = {t_target:.6g} failed ({failed.reason_name}); it is "
                f"cut in halves (history.csv column step_cuts){hint}",
                file=sys.stderr,
            )
        self.warned_cut = True
        self.advance(sim.t + (t_target - sim.t) / 2, cuts + 1, signals, callback)
        self.advance(t_target, cuts + 1, signals, callback)

    def after_step(self, signals: StopSignals, callback) -> None:
        """Record the new level, call back, checkpoint as asked, and stop on a signal."""
        sim, every = self.simulation, self.output.checkpoint_every
        self.record()
        if callback is not None:
            callback(sim)
        if every and sim.step_index % every == 0:
            self.last_saved = sim.save_checkpoint(self.checkpoints, self.columns)
        if sim.step_index % 100 == 0:  # cycles a callback may leave (the steps leave none)
            collect_garbage_together(self.comm, generation=1)
        number = signals.requested(self.comm)
        if number:
            raise RunInterrupted(number, sim.step_index, sim.t, self.save_on_stop())

    def record(self, write: bool = True) -> None:
        """Add the current level to the history, and write it (rows, fields, progress)."""
        sim = self.simulation
        values = sim.state(self.columns)
        self.history.append(values)
        if not write:
            return
        if self.writer is not None:
            self.writer.write(values)
        if self.fields is not None and sim.step_index % self.output.output_every == 0:
            self.fields.write(sim.t)
        self.progress.record(sim.step_index, sim.t, values)

    def save_on_stop(self) -> SavedState | None:
        """The checkpoint of the last completed step when a run stops early, if it has a place."""
        if self.checkpoints is None:
            return None
        sim = self.simulation
        if self.last_saved is not None and self.last_saved.step == sim.step_index:
            return self.last_saved
        return sim.save_checkpoint(self.checkpoints, self.columns)

    def close(self, collective: bool) -> None:
        """Close the history; the fields too when every rank gets here (collective)."""
        if self.progress is not None:
            self.progress.close()
        if self.writer is not None:
            self.writer.close()
        if collective and self.fields is not None:
            self.fields.close()
