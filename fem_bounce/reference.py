"""Published data shipped with the package (fem_bounce/data/*.csv; each file's header cites its source)."""
from __future__ import annotations

import csv
import io
from importlib import resources

import numpy as np


def table(name: str) -> list[dict]:
    """Rows of a packaged CSV as dicts, '#' comment lines skipped; numbers parsed where they parse."""
    text = (resources.files("fem_bounce") / "data" / f"{name}.csv").read_text()
    reader = csv.DictReader(io.StringIO("\n".join(line for line in text.splitlines() if not line.startswith("#"))))
    return [{k: _number(v) for k, v in row.items()} for row in reader]


def velocity_curve(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(t [s], velocity [m/s], negative = toward the wall) of a digitised experiment."""
    rows = table(name)
    return np.array([r["t_s"] for r in rows]), np.array([r["u_m_per_s"] for r in rows])


def velocity_curve_names() -> list[str]:
    """The packaged CSVs that hold a velocity curve (columns t_s and u_m_per_s)."""
    names = sorted(p.name[:-4] for p in (resources.files("fem_bounce") / "data").iterdir() if p.name.endswith(".csv"))
    return [name for name in names if {"t_s", "u_m_per_s"} <= set(next(iter(table(name)), {}))]


def _number(text: str):
    try:
        return float(text)
    except (TypeError, ValueError):
        return text
