"""One run of one model on one scene, with the outputs every model shares.

    summary = simulate(scene, "ode", comm, out_dir=Path("runs/case3"))

The model advances the flow (if any) and the shared BodyIntegrator; this module owns everything
around it: the run directory (output.py), the trajectory rows, the progress line, the checks every
model shares, restarts, the summary and the plots.  Before anything is written the model is built
(it checks the scene against itself) and, for a restart, the checkpoint, the scene and the
trajectory are checked, so a refused run changes nothing.

How a run ends (summary.json "status" and "stop_reason"):

- completed: end_time, the bounce limit, a sphere at rest on the wall (or, without gravity, stalled in
  the film: integrator.py), or a sphere lighter than the liquid stopped where it can no
  longer be followed: risen RISE_LIMIT diameters above its release, LID_GAP D below a container's lid, or at the
  top of a resolved model's refined region (it never reaches the wall);
- diverged (RunDiverged): NaN, a solver failure, the sphere inside the wall, or the sphere's energy
  1/2 m_p V^2 + (m_p - m_l) g h above its value at release, which the liquid can only take away;
- interrupted (RunInterrupted): SIGINT or SIGTERM, acted on between two steps on every rank together;
  the last checkpoint is kept and `--restart` continues from it;
- failed (RunFailed): an output could not be written (disk full, no permission).

Whatever the end, the summary is written with what was computed (when the disk allows) and the files
written so far are kept whole.
"""
from __future__ import annotations

import contextlib
import math
import signal
import time
import warnings
from pathlib import Path

import numpy as np
from petsc4py import PETSc

from . import bounces, cachedir, losses, models, output
from . import scene as scenes
from .errors import RunDiverged, RunFailed, RunInterrupted
from .flow_model import FlowModel
from .integrator import BodyIntegrator, PenetrationError
from .library_log import LIBRARY_LOG, library_output
from .progress import Interrupts, Monitor, ProgressBar, StopNow, on_root_watching, signal_name
from .steppers import Stepper, stepper_for

RISE_LIMIT = 10.0  # diameters above its release at which a rising (light) sphere is stopped
LID_GAP = 0.25  # and diameters below a container's lid (a mesh model's gap to the lid must still be meshed)
ENERGY_TOLERANCE = 0.10  # of |m_p - m_l| g h0: room for the integrators' error before a gain stops the run


def on_root(comm, action):
    """Run action on rank 0 and raise its exception on every rank, so all ranks fail alike; its
    result is returned on rank 0 (None elsewhere)."""
    error, result = None, None
    if comm.rank == 0:
        try:
            result = action()
        except Exception as err:  # noqa: BLE001 -- re-raised on every rank below
            error = err
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error
    return result


# -- what every step shares ----------------------------------------------------------------------


class RunIntegrator(BodyIntegrator):
    """The shared integrator, whose checkpoint state also carries the run's record (the trajectory's rows,
    put on the disk first; the wall time; the scene): every model that checkpoints the integrator, as it
    must to restart, so checkpoints the run whole."""

    record: "_RunRecord | None" = None

    def state_dict(self) -> dict:
        state = super().state_dict()
        if self.record is not None:
            state["run"] = self.record.checkpoint()
        return state


class _RunRecord:
    def __init__(self, scene, model_name: str, writers: dict[str, output.TrajectoryWriter], previous_wall: list):
        """`writers`: rank 0's trajectory.csv and side files by name (none elsewhere)."""
        self.scene_text = scenes.dumps(scene)
        self.model_name = model_name
        self.writers = writers
        self.previous_wall = list(previous_wall)  # earlier segments, each up to its last checkpoint [s]
        self.start = time.perf_counter()

    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def checkpoint(self) -> dict:
        """The record a checkpoint carries: every file's rows put on the disk first (rank 0)."""
        rows, error = {}, None
        for name, writer in self.writers.items():
            try:
                rows[name] = writer.sync()
            except output.OutputError as err:
                error = error or str(err)  # RunDirectory.commit_checkpoint refuses to commit then
        trajectory = rows.pop("trajectory.csv", None)
        return {"scene": self.scene_text, "model": self.model_name, "trajectory_rows": trajectory,
                "side_rows": rows, "trajectory_error": error, "wall_time_s": self.previous_wall + [self.elapsed()]}


class _Safeguards:
    """Checks after every integrator step (identical on every rank: the integrators are).

    The energy bound of free spheres: their kinetic energy and the potential energy of their net
    weights, sum_i 1/2 m_i V_i^2 + (m_i - m_l,i) g h_i, can never exceed its value at the start plus the
    kinetic energy the liquid can hold at the start, at most sum_i 1/2 m_l,i V_i0^2 (potential flow
    around a moving sphere, C_M = 1/2, and up to 0.80 at contact: taken as 1): the elastic energy and
    the liquid's are >= 0 and viscosity only dissipates.  A held or prescribed sphere is worked on by its
    prescription, so the bound is not checked then.  Spheres all lighter than the liquid are stopped
    where sphere 1 can no longer be followed (they never reach the wall)."""

    def __init__(self, scene, integrator: BodyIntegrator, info, resolved_top: float):
        """`info`: the model's models.registry.ModelInfo; `resolved_top` [m]: FlowModel.resolved_top."""
        self.scene, self.integrator, self.info = scene, integrator, info
        bodies = integrator.bodies
        self.free = all(body.free for body in bodies)
        self.masses = np.array([body.mass for body in bodies])
        displaced = np.array([body.displaced_mass for body in bodies])
        self.weights = np.array([body.net_weight for body in bodies])
        v0 = np.array([body.start_velocity for body in bodies]) if self.free else np.zeros(len(bodies))
        h0 = np.array([body.initial_gap for body in bodies])
        launch = 0.5 * (self.masses + displaced) @ v0**2
        if integrator.pair_frame is not None:  # a pair off its line of centres trades the energy across it with V's
            tangential = integrator.tangential
            launch += tangential.kinetic_energy(tangential.start, displaced)
        self.release_energy = self.weights @ h0 + launch
        self.tolerance = ENERGY_TOLERANCE * (np.abs(self.weights) @ h0 + launch)
        # buoyancy lifts them (without gravity nothing does); launched at the wall they may still reach it
        self.light = self.free and all(self.weights < 0.0)
        self.launched_down = bool(v0[0] < 0.0)
        d = bodies[0].diameter
        limits = [(h0[0] + RISE_LIMIT * d, f"risen {RISE_LIMIT:g} D above its release")]
        if not scene.container.unbounded:
            limits.append((scene.container.height - (1.0 + LID_GAP) * d,
                           f"come within {LID_GAP:g} D of the container's lid"))
        if math.isfinite(resolved_top):
            limits.append((resolved_top - d, f"reached the top of the {info.name} model's refined region"))
        self.ceiling, self.where = min(limits)
        self.stop_reason: str | None = None

    def __call__(self, row: dict) -> None:
        if not self.free:
            return
        integrator = self.integrator
        h, v, d = integrator.gaps, integrator.velocities, integrator.bodies[0].diameter
        excess = 0.5 * self.masses @ (v * v) + integrator.across_energy + self.weights @ h - self.release_energy
        if excess > self.tolerance:
            hint = self.info.unstable_hint(self.scene)
            where = ", ".join(f"{x / d:.3g}" for x in h)
            speeds = ", ".join(f"{x:+.3g}" for x in v)
            what = "the sphere" if len(h) == 1 else "the spheres"
            raise RunDiverged(
                f"{what} gained energy {'it' if len(h) == 1 else 'they'} cannot have: at t = {row['t']:.6g} s (gap "
                f"{where} D, V = {speeds} m/s) the kinetic + potential energy is "
                f"{excess / self.tolerance * ENERGY_TOLERANCE:.0%} of its scale above its bound at release; the "
                f"coupling or the time step is unstable ({hint})")
        if self.light and h[0] >= self.ceiling and self.stop_reason is None:
            self.stop_reason = (f"the light sphere has {self.where} (gap {h[0] / d:.3g} D at t = {row['t']:.4g} s); "
                                "it never reaches the wall")
            integrator.done = True


# -- after an interruption -------------------------------------------------------------------------


def _interruption_note(run_dir: output.RunDirectory, info) -> str:
    """What the user can do after an interruption (rank 0)."""
    if not info.restarts:
        return f"; the {info.name} model writes no checkpoints: run it again"
    if run_dir.checkpoint is None:
        return f"; no checkpoint was written yet ({info.checkpoint_every_key}), so it cannot be continued"
    state = run_dir.checkpoint.state
    return (f"; continue from its last checkpoint (step {state.get('step')}, t = {state.get('time', 0.0):.6g} s) "
            f"with: fem-bounce run --restart {run_dir.path}")


# -- the time loop ---------------------------------------------------------------------------------


class Every:
    """Call `action()` after every `every`-th step (never when every = 0)."""

    def __init__(self, every: int, action):
        self.every, self.action = every, action

    def __call__(self, step: int) -> None:
        if self.every and step % self.every == 0:
            self.action()


class Controller:
    """The one time loop every model runs under: it builds the flow model, lets the stepper the registry
    names for it (fem_bounce.steppers) advance the flow and the bodies, and after each step calls the
    observers (progress and stop requests; field snapshots and checkpoints on their cadences); it stops at
    the end time or when the integrator is done, and turns the model's failures into one RunDiverged that
    says where the run can be continued from.  What a model is comes in resolved (`info`, its
    models.registry.ModelInfo): the controller knows nothing of pairs, time-step keys or meshes."""

    def __init__(self, flow_model: FlowModel, info, integrator: BodyIntegrator, monitor=None,
                 run_dir: output.RunDirectory | None = None, sides: dict | None = None):
        """`monitor(t, steps, gaps, velocities, force=False)` is called after every step (the run's progress
        line and stop requests); without `run_dir` nothing is written.  `sides`: rank 0's writers of the model's
        side files (FlowModel.side_files), by name."""
        self.flow_model, self.info, self.integrator, self.comm = flow_model, info, integrator, flow_model.comm
        self.monitor = monitor or (lambda *args, **kwargs: None)
        self.run_dir = run_dir
        self.sides = sides or {}
        self.fields_every, self.checkpoint_every = info.cadences(flow_model.scene) if run_dir is not None else (0, 0)
        self.last_checkpoint: tuple[int, float] | None = None
        self.stepper: Stepper | None = None

    def run(self, resumed: output.Checkpoint | None = None, started=None) -> dict:
        """The run from its start, or from `resumed` (a restart: the checkpoint RunDirectory.resume chose);
        `started()` once it is restored (a refused restart has changed nothing)."""
        flow_model, integrator, run_dir = self.flow_model, self.integrator, self.run_dir
        restart, fields_every = resumed is not None, self.fields_every
        try:
            flow_model.build(integrator)
            self.stepper = stepper = stepper_for(self.info, flow_model, integrator)
            if restart:
                self._restore(resumed)
            if run_dir is not None:
                on_root(self.comm, run_dir.begin)  # a restart: the checkpoint restored, its files cut back
            if started is not None:
                started()
            self._progress()  # a signal that came while the model was built stops the run here, on every rank
            first_step = flow_model.step
            observers = [self._progress]
            if run_dir is not None:
                flow_model.open_outputs(run_dir.path, restart, fields=bool(fields_every), sides=self.sides)
                if fields_every:
                    if not restart:
                        flow_model.write_fields(integrator.time)
                    observers.append(Every(fields_every, lambda: flow_model.write_fields(integrator.time)))
            if self.checkpoint_every:
                observers.append(Every(self.checkpoint_every, self.save_checkpoint))
            start = time.perf_counter()

            def after_step() -> None:
                for observer in observers:
                    observer(stepper.steps)

            stepper.run(flow_model.scene.run.end_time, after_step)
            self._progress(force=True)
            flow_model.loop_seconds = time.perf_counter() - start
            flow_model.steps_this_run = flow_model.step - first_step
            if (fields_every and flow_model.fields_at_end
                    and (flow_model.steady or flow_model.step % fields_every)):
                flow_model.write_fields(integrator.time)
            report = flow_model.report()
            return {"steps": stepper.steps, "sizes": flow_model.sizes(),
                    "extra": {flow_model.name: report} if report else {}}
        except (PenetrationError, ArithmeticError, PETSc.Error, *flow_model.divergences) as err:
            raise RunDiverged(f"{self._explain(err)} ({self._where()})") from err
        finally:
            if run_dir is not None:
                flow_model.close_outputs()
            flow_model.destroy()

    def _progress(self, step: int | None = None, force: bool = False) -> None:
        integrator = self.integrator
        self.monitor(integrator.time, self.stepper.steps, integrator.gaps, integrator.velocities, force=force)

    def _explain(self, err: BaseException) -> str:
        integrator = self.integrator
        if isinstance(err, PETSc.Error):
            return (f"t = {integrator.time:.5g} s: a solver failed (PETSc error {err.ierr}): the coupling or the "
                    "time step went unstable")
        if isinstance(err, ArithmeticError) and not isinstance(err, FloatingPointError):
            speed = ", ".join(f"{v:.3g}" for v in integrator.velocities)
            return (f"the coupled step broke down ({type(err).__name__}: {err}) near t = {integrator.time:.6g} s "
                    f"with the sphere at {speed} m/s: {self.info.breakdown_cause(self.flow_model.scene)}")
        return str(err)

    def _where(self) -> str:
        if not self.checkpoint_every:
            return f"at step {self.stepper.steps}"  # the ode model's stepper takes the whole run
        if self.last_checkpoint is None:
            return "no checkpoint yet"
        return f"last checkpoint at step {self.last_checkpoint[0]}, t = {self.last_checkpoint[1]:.6g} s"

    # -- checkpoints: the flow, the stepper (its predictor), the integrator (which carries the run record) --
    def save_checkpoint(self) -> None:
        flow_model, integrator, comm = self.flow_model, self.integrator, self.comm
        if flow_model.ended_short:  # continued past its end time, the run goes on from the checkpoint before
            return
        flow, arrays = flow_model.checkpoint_state()  # collective; arrays on rank 0
        state = {"step": flow_model.step, "time": integrator.time, "ranks": comm.size, **self.stepper.state(),
                 "flow": flow, "integrator": integrator.state_dict()}

        data, = self.info.checkpoint_files
        on_root(comm, lambda: self.run_dir.commit_checkpoint(flow_model.name, state, data, arrays))
        self.last_checkpoint = (flow_model.step, integrator.time)

    def _restore(self, resumed: output.Checkpoint) -> None:
        """Continue from `resumed` (RunDirectory.resume has checked it; begin() cuts the trajectory back)."""
        data, = self.info.checkpoint_files
        arrays, state = resumed.arrays(data), resumed.state
        failure = None
        try:
            self.flow_model.restore(state["flow"], arrays)
            self.flow_model.step = state["step"]
            self.stepper.restore(state)
            self.integrator.load_state_dict(state["integrator"])
        except output.CheckpointError as err:  # on one rank (a dof of its part that fits no stored one)
            failure = str(err)
        except (KeyError, TypeError, ValueError, IndexError, AttributeError, ArithmeticError,
                np.linalg.LinAlgError, PETSc.Error) as err:  # what check_checkpoint cannot see: the model's own part
            failure = (f"its state does not fit the {self.info.name} model ({type(err).__name__}: {err}): damaged, "
                       "edited or written by another model")
        failures = [f for f in self.comm.allgather(failure) if f]
        if failures:
            raise output.CheckpointError(f"the checkpoint in {self.run_dir.path} cannot continue this run: "
                                         f"{failures[0]}")
        self.last_checkpoint = (state["step"], state["time"])


def check_checkpoint(checkpoint: output.Checkpoint, integrator: BodyIntegrator) -> output.Checkpoint:
    """The parts of a checkpoint's state.json that every model shares, checked before anything is built or
    changed: the controller's step and time, the stepper's velocities, and the body integrator's state (its
    length, finite numbers, its records); CheckpointError naming the entry otherwise.  A model checks its own
    part as it restores it (Controller._restore)."""
    state, bodies = checkpoint.state, len(integrator.bodies)

    def bad(entry: str, what: str) -> output.CheckpointError:
        return output.CheckpointError(f"the checkpoint in {checkpoint.folder.parent} is unreadable: "
                                      f"{checkpoint.folder.name}/state.json: {entry} {what} (damaged or edited); "
                                      "start a new run")

    def number(value, low: float = 0.0) -> bool:
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value >= low

    def numbers(values, count: int) -> bool:
        return isinstance(values, list) and len(values) == count and all(number(v, -math.inf) for v in values)

    if not (isinstance(state.get("step"), int) and not isinstance(state["step"], bool) and state["step"] >= 0):
        raise bad("step", f"= {state.get('step')!r} is not a whole number of steps")
    if not number(state.get("time")):
        raise bad("time", f"= {state.get('time')!r} is not a time >= 0 s")
    if not isinstance(state.get("flow"), dict):
        raise bad("flow", "is not a table of the model's state")
    velocities = state.get("velocities", [])
    if not (isinstance(velocities, list)
            and all(numbers(v, bodies) or (bodies == 1 and number(v, -math.inf)) for v in velocities)):
        raise bad("velocities", f"is not a list of {bodies} finite velocities per level")
    saved = state.get("integrator")
    if not isinstance(saved, dict):
        raise bad("integrator", "is not a table")
    if not number(saved.get("time")):
        raise bad("integrator.time", f"= {saved.get('time')!r} is not a time >= 0 s")
    if not number(saved.get("step_size")):  # 0 can be saved: RunIntegrator.advance restarts it
        raise bad("integrator.step_size", f"= {saved.get('step_size')!r} is not a step >= 0 s")
    if not numbers(saved.get("y"), integrator.n):
        raise bad("integrator.y", f"is not {integrator.n} finite numbers (the bodies' gaps, velocities and history)")
    machine = saved.get("machine")
    if not (isinstance(machine, dict) and isinstance(machine.get("done"), bool)
            and isinstance(machine.get("steps"), int) and not isinstance(machine["steps"], bool)
            and machine["steps"] >= 0):
        raise bad("integrator.machine", "is not a table of done (true or false) and steps (a whole number)")
    records, names = saved.get("records"), {contact.name for contact in integrator.contacts}
    if not (isinstance(records, dict) and set(records) == names and all(isinstance(r, dict) for r in records.values())):
        raise bad("integrator.records", f"is not a table of the contacts {', '.join(sorted(names))}")
    for name, record in records.items():
        if (wrong := bounces.state_error(record)) is not None:
            raise bad(f"integrator.records.{name}.{wrong[0]}", wrong[1])
    return checkpoint


# -- the run --------------------------------------------------------------------------------------


def simulate(scene, model_name: str, comm, out_dir: Path | None = None, *, force: bool = False,
             restart: bool = False, command: str = "", progress: bool = True, plots: bool = True,
             interrupts: Interrupts | None = None, on_start=None) -> dict:
    """Run the model named `model_name` on `scene`; write DIR/{scene.toml,trajectory.csv,summary.json,*.png}
    if out_dir is given.  `on_start()` is called on rank 0 once nothing can refuse the run any more (the command
    line's start line: a refusal prints only its one line).
    Raises RunDiverged, RunInterrupted or RunFailed after writing the summary when the run ends early."""
    info = models.info(model_name)  # what the model is, resolved once and handed down
    if info.serial and comm.size > 1:
        return _serial_on_root(scene, model_name, comm, out_dir, force=force, restart=restart, command=command,
                               progress=progress, plots=plots, interrupts=interrupts, on_start=on_start)
    run = _Run(scene, info, comm, None if out_dir is None else Path(out_dir), interrupts or Interrupts.active)
    run.prepare(force, restart, progress, on_start)
    return run.conclude(*run.advance(on_start if restart and comm.rank == 0 else None), command, plots)


class _Run:
    """One run in three steps, each owning what it opens: `prepare` (everything that can refuse the run, before
    anything is written; then the run directory and its files), `advance` (the Controller; how it ended) and
    `conclude` (the stop reason, the summary, the audit and the figures; the outcome raised or returned)."""

    def __init__(self, scene, info, comm, out_dir: Path | None, interrupts: Interrupts | None):
        self.scene, self.info, self.comm, self.out_dir, self.interrupts = scene, info, comm, out_dir, interrupts
        self.run_dir: output.RunDirectory | None = None
        self.resumed: output.Checkpoint | None = None  # the checkpoint a restart continues (rank 0 checks it)
        self.files: dict[str, output.TrajectoryWriter] = {}  # trajectory.csv and the model's side files (rank 0)

    def prepare(self, force: bool, restart: bool, progress: bool, on_start) -> None:
        scene, info, comm, out_dir = self.scene, self.info, self.comm, self.out_dir
        model_name = info.name
        # Everything that can refuse the run comes before anything is written.
        models.check_scene(info, scene)
        cachedir.checked_root()  # where the resolved models' meshes go
        model_cls = models.flow_model_class(info, scene)
        root = comm.rank == 0
        if restart:
            if not info.restarts:
                raise models.ModelError(f"the {model_name} model writes no checkpoints, so it cannot --restart: run "
                                        "it again")
            if out_dir is None:
                raise output.OutputError("a restart needs the run directory it continues")
        self.flow_model = flow_model = model_cls(scene, comm)
        self.integrator = integrator = RunIntegrator(scene, resolved=model_cls.resolved)
        self.guards = guards = _Safeguards(scene, integrator, info, flow_model.resolved_top())
        if root:
            if guards.light:
                fate = ("buoyancy slows the launched sphere, which may turn back before the wall; if it does, the run"
                        if guards.launched_down else "the sphere rises and never reaches the wall; the run")
                warnings.warn(f"sphere.density = {scene.sphere.density:g} kg/m3 is below liquid.density = "
                              f"{scene.liquid.density:g} kg/m3: {fate} "
                              f"stops when it has {guards.where} (gap {guards.ceiling / scene.sphere.diameter:.3g} D)",
                              stacklevel=3)
            for message in info.scene_warnings(scene):
                warnings.warn(message, stacklevel=3)
        if out_dir is not None:
            self.run_dir = run_dir = output.RunDirectory(out_dir)
            if restart:
                self.resumed = comm.bcast(on_root(comm, lambda: check_checkpoint(
                    run_dir.resume(scene, model_name, info.checkpoint_files), integrator)), 0)
            else:
                on_root(comm, lambda: run_dir.prepare(force, scene))
            interval_key = info.trajectory_interval_key
            interval = info.setting(scene, interval_key) if interval_key else 0.0
            columns = output.trajectory_columns(len(scene.spheres), scene.oblique)

            def open_files():
                run_dir.reserve()
                files = {"trajectory.csv": run_dir.trajectory(interval, columns)}
                return {**files, **{name: run_dir.trajectory(0.0, side_columns, name)
                                    for name, side_columns in flow_model.side_files().items()}}

            try:
                self.files = on_root(comm, open_files) or {}  # refused for want of room: nothing left behind
            except output.OutputError:
                on_root(comm, run_dir.abandon)
                raise
        if root and on_start is not None and not restart:
            on_start()
        self.earlier_wall = self.resumed.wall_time_s if self.resumed is not None else []  # [s], one per segment
        writer = self.files.get("trajectory.csv")
        self.record = _RunRecord(scene, model_name, self.files, self.earlier_wall)
        integrator.record = self.record
        if writer is not None:
            integrator.observers.append(writer)
        integrator.observers.append(guards)
        self.bar = ProgressBar(scene.run.end_time, [body.diameter for body in integrator.bodies],
                               enabled=progress and root)
        self.monitor = Monitor(self.bar, comm, self.interrupts, list(self.record.writers.values()), scene.time_unit)

    def _close_files(self) -> None:
        for each in self.record.writers.values():
            each.close()

    def advance(self, started) -> tuple[str, str, int, dict]:
        """(status, message, signal number, the controller's result), the same on every rank."""
        integrator, comm = self.integrator, self.comm
        sides = {name: each for name, each in self.files.items() if name != "trajectory.csv"}
        status, message, signum = "completed", "", 0
        result: dict = {}
        try:
            result = Controller(self.flow_model, self.info, integrator, self.monitor, self.run_dir, sides).run(
                self.resumed, started=started)
        except output.CheckpointError:
            # the restart could not load its checkpoint: no summary for a run that never continued, and DIR as it was
            self.bar.close()
            with contextlib.suppress(output.OutputError):
                self._close_files()
            if self.run_dir is not None:
                on_root(comm, self.run_dir.release)
            raise
        except (PenetrationError, FloatingPointError, RunDiverged) as err:
            status, message = f"diverged: {err}", str(err)
        except RunInterrupted as err:
            status, message, signum = "interrupted", str(err), err.signum
        except KeyboardInterrupt as err:  # a second signal, or Ctrl-C with no Interrupts installed
            signum = getattr(err, "signum", signal.SIGINT)
            status, message = "interrupted", f"interrupted by {signal_name(signum)} at t = {integrator.time:.6g} s"
        except (RunFailed, output.OutputError) as err:
            status, message = f"failed: {err}", str(err)
        self.bar.close()
        try:
            self._close_files()
        except output.OutputError as err:
            if status == "completed":
                status, message = f"failed: {err}", str(err)
        # rank 0 alone writes, so rank 0's account of how the run ended is every rank's
        status, message, signum = comm.bcast((status, message, signum), root=0)
        return status, message, signum, result

    def _stop_reason(self, status: str, message: str) -> str:
        scene, integrator = self.scene, self.integrator
        if status != "completed":
            return message
        if self.guards.stop_reason is not None:
            return self.guards.stop_reason
        if integrator.done:
            return integrator.stop_reason or f"the bounce limit (run.bounces = {scene.run.bounces})"
        return f"run.end_time = {scene.run.end_time:g} s"

    def conclude(self, status: str, message: str, signum: int, result: dict, command: str, plots: bool) -> dict:
        scene, integrator, comm, out_dir, run_dir = self.scene, self.integrator, self.comm, self.out_dir, self.run_dir
        stop_reason = self._stop_reason(status, message)
        integrator.finish()
        wall, earlier_wall = self.record.elapsed(), self.earlier_wall
        extra = {**(result.get("extra") or {}), "stop_reason": stop_reason}
        if earlier_wall:
            extra["wall_time_segments_s"] = earlier_wall + [wall]
        data = output.summary(scene, self.info.name, integrator, sum(earlier_wall) + wall,
                              result.get("steps", self.monitor.steps or integrator.steps), comm.size, command,
                              status=status, sizes=result.get("sizes"), extra=extra)
        integrator.destroy()
        unwritten = ""
        if run_dir is not None:
            try:
                message += on_root(comm, lambda: self._write_outputs(data, status, plots)) or ""  # rank 0's note
            except output.OutputError as err:
                if status == "completed":
                    raise RunFailed(str(err)) from None
                unwritten = f" ({err})"
            finally:
                on_root(comm, run_dir.release)
        if status == "completed":
            return data
        if status == "interrupted":
            raise RunInterrupted(message + unwritten, signum)
        kept = f"; outputs kept in {out_dir}" if out_dir is not None else ""
        if status.startswith("diverged"):
            raise RunDiverged(f"{status}{kept}{unwritten}")
        raise RunFailed(f"{message}{kept}{unwritten}")

    def _write_outputs(self, data: dict, status: str, plots: bool) -> str:
        """The summary with its loss audit and the figures (rank 0); a note for an interrupted run."""
        out_dir, run_dir, interrupts = self.out_dir, self.run_dir, self.interrupts
        trajectory = None  # read once, for the audit and the figures
        with contextlib.suppress(OSError, ValueError, KeyError):  # a trajectory that cannot be read: no audit
            trajectory = output.read_trajectory(out_dir)
            unaudited = losses.annotate(data, trajectory)
            if unaudited and status == "completed":  # (an unfinished run's rows may end before an impact's)
                warnings.warn(unaudited, stacklevel=2)
        run_dir.commit_summary(data)
        if plots and (status == "completed" or status.startswith("diverged")):
            try:  # not after an interruption (OpenMPI kills 1 s after its SIGTERM) nor a failure
                _draw(out_dir, trajectory, data)
                if interrupts is not None and interrupts.signum:  # a signal while drawing only set its flag
                    raise StopNow(interrupts.signum)
            except KeyboardInterrupt as err:  # Ctrl-C with no Interrupts installed (the API), or the above
                stopped = getattr(err, "signum", signal.SIGINT)
                reason = f"interrupted by {signal_name(stopped)} while drawing the figures"
                run_dir.commit_summary({**data, "status": "interrupted", "stop_reason": reason})
                raise RunInterrupted(f"{reason}; the run itself {status} (summary.json, trajectory.csv)",
                                     stopped) from None
        return _interruption_note(run_dir, self.info) if status == "interrupted" else ""


def _serial_on_root(scene, model_name: str, comm, out_dir: Path | None, *, on_start=None, **options) -> dict:
    """A serial model under mpiexec: rank 0 runs it on COMM_SELF while the other ranks wait without
    spinning, then every rank gets rank 0's summary, or its exception (progress.on_root_watching), so that no
    rank repeats the same serial solve and every rank ends the same way.  It says so once nothing can refuse
    the run any more (a refusal is its one line alone)."""
    from mpi4py import MPI

    def started() -> None:
        warnings.warn(f"the {model_name} model is serial: under mpiexec it runs on rank 0 alone and the other "
                      f"{comm.size - 1} rank(s) wait (no speed-up); run it without mpiexec, or spread a study's "
                      "runs with --jobs N or --executor mpi", stacklevel=2)
        if on_start is not None:
            on_start()
    return on_root_watching(comm, lambda: simulate(scene, model_name, MPI.COMM_SELF, out_dir, on_start=started,
                                                   **options))


def _draw(out_dir: Path, trajectory: dict | None, summary: dict) -> None:
    """The run's figures from what it has just written (`trajectory`: None when it could not be read back)."""
    from . import plots as drawing  # matplotlib (and its Agg backend) only for a run that draws

    try:
        drawing.draw_run(out_dir, trajectory, summary)
    except OSError as err:
        raise output.OutputError(f"cannot draw the figures in {out_dir}: {err.strerror or err}") from None


# -- a run as `fem-bounce run` and fem_bounce.simulate start it ----------------------------------------------


def run_logged(scene, model_name: str, comm, out_dir: Path, **options) -> dict:
    """One run as `fem-bounce run` and fem_bounce.simulate make it: simulate(**options) with what the libraries
    say kept for out_dir/run.log once the run has begun (a refused run leaves out_dir as it was; library_log)."""
    with library_output():
        try:
            summary = simulate(scene, model_name, comm, out_dir, **options)
        except RunFailed:  # diverged, interrupted or failed: begun, so its directory is a run's
            LIBRARY_LOG.keep(out_dir, comm)
            raise
        LIBRARY_LOG.keep(out_dir, comm)
    return summary


def restart_target(run_dir: Path, requested: str | None) -> tuple[scenes.Scene, str]:
    """The scene (DIR/scene.toml) and the model (the one that wrote DIR's checkpoint) a restart of run_dir
    continues (`fem-bounce run --restart DIR`, fem_bounce.resume); `requested`, when given, must be that model."""
    model = output.RunDirectory(run_dir).newest_checkpoint().model
    if model not in models.registry.restarting():
        raise models.ModelError(f"the checkpoint in {run_dir} names the model {model!r}, which writes no "
                                f"checkpoints (only {', '.join(models.registry.restarting())} can --restart): "
                                "it is not a checkpoint this version wrote")
    if requested and requested != model:
        raise models.ModelError(f"{run_dir} was run with --model {model}, not {requested}")
    scene = scenes.load(run_dir / "scene.toml")
    models.get(model)
    return scene, model
