"""One run of one model on one scene, with the outputs every model shares.

    summary = simulate(scene, "ode", comm, out_dir=Path("runs/case3"))

The model advances the flow (if any) and the shared SphereIntegrator; this
module owns everything around it: the run directory, the trajectory rows, the
progress line, the summary and the plots.  A run that diverges (sphere inside
the wall, NaN, solver failure) still writes its summary with the reason and
raises RunDiverged, keeping whatever it wrote so far.
"""
from __future__ import annotations

import time
from pathlib import Path

from . import models, output
from .contact import ContactModel
from .sphere import PenetrationError, SphereIntegrator


class RunDiverged(RuntimeError):
    pass


def _on_root(comm, action):
    """Run action on rank 0 and raise its exception on every rank, so all ranks fail alike."""
    error = None
    if comm.rank == 0:
        try:
            action()
        except Exception as err:  # noqa: BLE001 -- re-raised on every rank below
            error = err
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error


def simulate(scene, model: str, comm, out_dir: Path | None = None, *, force: bool = False,
             restart: bool = False, command: str = "", progress: bool = True, plots: bool = True) -> dict:
    """Run `model` on `scene`; write DIR/{scene.toml,trajectory.csv,summary.json,*.png} if out_dir is given."""
    model_cls = models.get(model)
    root = comm.rank == 0
    if out_dir is not None:
        out_dir = Path(out_dir)
        _on_root(comm, lambda: output.prepare_directory(out_dir, force=force, resume=restart))
        if root and not restart:
            output.write_scene(out_dir / "scene.toml", scene)
    integrator = SphereIntegrator(scene, ContactModel(scene), resolved=model_cls.resolved)
    interval = scene.numerics.ode.output_interval if model == "ode" else 0.0
    writer = output.TrajectoryWriter(out_dir / "trajectory.csv" if (root and out_dir) else None, interval,
                                     append=restart)
    integrator.observers.append(writer)
    bar = output.Progress(scene.run.end_time, scene.sphere.diameter, enabled=progress and root)
    start = time.perf_counter()
    status, error = "completed", None
    result: dict = {}
    try:
        solver = model_cls(scene, comm)
        result = solver.run(integrator, bar, out_dir, restart) or {}
    except (PenetrationError, FloatingPointError, RunDiverged) as err:
        status, error = f"diverged: {err}", err
    finally:
        writer.close()
        bar.close()
    integrator.finish()
    wall = time.perf_counter() - start
    data = output.summary(scene, model, integrator, wall, result.get("steps", integrator.steps), comm.size, command,
                          status=status, sizes=result.get("sizes"), extra=result.get("extra"))
    if root and out_dir is not None:
        output.write_summary(out_dir / "summary.json", data)
        if plots:
            from . import plots as drawing

            drawing.draw_run(out_dir)
    if error is not None:
        raise RunDiverged(f"{status}; outputs kept in {out_dir}" if out_dir else status) from error
    return data
