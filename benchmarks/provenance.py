"""Where a benchmark's record came from: imported by the scripts beside it (`python benchmarks/NAME.py` puts
this folder on the path)."""
from __future__ import annotations

import platform
import subprocess
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def commit() -> str:
    """The commit the script runs at (a + when the work tree differs from it; "?" when git is not installed)."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=False).stdout
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, check=False).stdout
    except OSError:
        return "?"
    return head.strip() + ("+" if dirty.strip() else "")


def stamp() -> dict:
    """When, where and at which commit a record was made: "date" (local time, YYYY-MM-DDTHH:MM:SS), "machine"
    (the host's name) and "commit", the keys the records in history/ already have."""
    return {"date": time.strftime("%Y-%m-%dT%H:%M:%S"), "machine": platform.node(), "commit": commit()}
