"""Checkpoints of an fd run: everything needed to continue a killed run to the same result.

    DIR/checkpoint/model.txt     "fd" (the CLI reads it to pick the model on --restart)
    DIR/checkpoint/state.json    step, time, the sphere's velocity/interior history, the integrator's state
    DIR/checkpoint/flow.npz      the flow's BDF history (u, p at t_n, t_{n-1}, ...) by dof coordinates

The flow is stored by dof coordinates (fem.functions), so a run checkpointed on two
ranks can restart on one.  A new checkpoint is written beside the old one and then
swapped in, so a kill during writing leaves the previous checkpoint intact; only
rank 0 writes, every rank reads.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from ...fem.functions import gather_values, scatter_values

MODEL_NAME = "fd"


def directory(out_dir: Path) -> Path:
    return Path(out_dir) / "checkpoint"


def save(comm, out_dir: Path, state: dict, flow_states: list) -> None:
    """Write state (JSON-able) and the flow's history functions; collective."""
    gathered = [gather_values(function) for function in flow_states]
    if comm.rank == 0:
        final = directory(out_dir)
        partial = final.with_name("checkpoint.partial")
        if partial.exists():
            shutil.rmtree(partial)
        partial.mkdir(parents=True)
        arrays = {}
        for level, data in enumerate(gathered):
            for name, (coordinates, values) in data.items():
                arrays[f"x_{level}_{name}"] = coordinates
                arrays[f"v_{level}_{name}"] = values
        np.savez(partial / "flow.npz", **arrays)
        (partial / "state.json").write_text(json.dumps(state, indent=1))
        (partial / "model.txt").write_text(MODEL_NAME + "\n")
        old = final.with_name("checkpoint.old")
        if final.exists():
            final.replace(old)
        partial.replace(final)
        if old.exists():
            shutil.rmtree(old)
    comm.barrier()


def load(out_dir: Path, flow_states: list, tolerance: float) -> dict:
    """Set the flow's history functions and return the saved state; every rank reads."""
    folder = directory(out_dir)
    state = json.loads((folder / "state.json").read_text())
    with np.load(folder / "flow.npz") as arrays:
        for level, function in enumerate(flow_states):
            names = sorted(k[len(f"x_{level}_"):] for k in arrays.files if k.startswith(f"x_{level}_"))
            data = {name: (arrays[f"x_{level}_{name}"], arrays[f"v_{level}_{name}"]) for name in names}
            scatter_values(function, data, tolerance)
    return state


def truncate_trajectory(path: Path, end_time: float) -> None:
    """Drop trajectory rows written after the checkpoint (rank 0), so the restarted run appends cleanly."""
    path = Path(path)
    if not path.is_file():
        return
    with open(path, newline="") as stream:  # keep the csv module's line endings
        lines = stream.readlines()
    keep = lines[:1] + [line for line in lines[1:] if float(line.split(",", 1)[0]) <= end_time * (1 + 1e-12)]
    with open(path, "w", newline="") as stream:
        stream.writelines(keep)
