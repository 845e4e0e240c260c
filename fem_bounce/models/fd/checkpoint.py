"""Checkpoints of an fd run: everything needed to continue a killed run to the same result.

    DIR/checkpoint/flow.npz      the flow's BDF history (u, p at t_n, t_{n-1}, ...) by dof coordinates
    DIR/checkpoint/state.json    step, time, the sphere's velocity/interior history, the integrator's state
                                 (which carries the run's record: scene, trajectory rows, wall time)
    DIR/checkpoint/model.txt     "fd", written last (the CLI reads it to pick the model on --restart)

The flow is stored by dof coordinates (fem.functions), so a run checkpointed on two
ranks can restart on one.  The folder is written and swapped in by output.commit_checkpoint:
a kill at any moment leaves a whole checkpoint; only rank 0 writes, every rank reads.
A write that fails (disk full) raises the same OutputError on every rank.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import output
from ...fem.functions import CheckpointMismatch, gather_values, scatter_values

MODEL_NAME = "fd"
DATA_FILES = ("flow.npz",)


def directory(out_dir: Path) -> Path:
    return Path(out_dir) / output.CHECKPOINT


def save(comm, out_dir: Path, state: dict, flow_states: list) -> None:
    """Write state (JSON-able) and the flow's history functions; collective."""
    gathered = [gather_values(function) for function in flow_states]
    error = None
    if comm.rank == 0:
        arrays = {}
        for level, data in enumerate(gathered):
            for name, (coordinates, values) in data.items():
                arrays[f"x_{level}_{name}"] = coordinates
                arrays[f"v_{level}_{name}"] = values
        try:
            output.commit_checkpoint(out_dir, MODEL_NAME, lambda folder: np.savez(folder / "flow.npz", **arrays), state)
        except output.OutputError as err:
            error = err
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error


def load(out_dir: Path, flow_states: list, tolerance: float) -> dict:
    """Set the flow's history functions and return the saved state; every rank reads.  The run
    module has checked the checkpoint and made it DIR/checkpoint before the model starts."""
    found = output.find_checkpoint(out_dir, required=DATA_FILES)
    try:
        with np.load(found.folder / "flow.npz") as arrays:
            for level, function in enumerate(flow_states):
                names = sorted(k[len(f"x_{level}_"):] for k in arrays.files if k.startswith(f"x_{level}_"))
                if not names:
                    raise CheckpointMismatch(f"flow.npz has no flow at time level {level}")
                data = {name: (arrays[f"x_{level}_{name}"], arrays[f"v_{level}_{name}"]) for name in names}
                scatter_values(function, data, tolerance)
    except (OSError, ValueError, KeyError, CheckpointMismatch) as err:
        raise output.CheckpointError(f"the checkpoint in {out_dir} does not fit this run's mesh: {err}") from None
    return found.state
