"""Li, Hunt & Colonius (2011) Table 2 against a model: first impact speed, Re_I and Re_II for cases 1-7.

    python benchmarks/table2.py --model ode                      # ~5 s
    mpiexec -n 2 python benchmarks/table2.py --model fd           # minutes to hours, see docs/validation.md section 4

Writes results/table2-MODEL/{table2.md,table2.json} and keeps each case's run directory beside them
(re-running reuses finished runs unless --force).  A run of all seven cases also goes to
benchmarks/history/<out's name>.json (table2-MODEL.json by default), with its --set, date, machine and commit.
"""
from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

from mpi4py import MPI

from fem_bounce import reference, scene
from fem_bounce.errors import RunDiverged
from fem_bounce.run import run_logged as simulate  # the libraries' output goes to the run's run.log
from provenance import commit


def run_case(case: int, model: str, out: Path, overrides: dict, force: bool, comm) -> dict:
    run_dir = out / f"case{case}"
    summary_path = run_dir / "summary.json"
    if summary_path.exists() and not force:
        return json.loads(summary_path.read_text())
    sc = scene.load(f"li2011-case{case}", {"run.bounces": 2, **overrides})
    try:
        return simulate(sc, model, comm, run_dir, force=True, progress=False, command=f"table2.py case {case}")
    except RunDiverged:
        return json.loads(summary_path.read_text())


def row(case_ref: dict, summary: dict) -> dict:
    impacts = summary["impacts"]
    first = impacts[0] if impacts else None
    second = impacts[1] if len(impacts) > 1 else None

    def err(model_value, measured):
        return None if model_value is None else 100.0 * (model_value / measured - 1.0)

    v_i = first["impact_speed"] if first else None
    re_1 = first["Re"] if first else None
    re_2 = second["Re"] if second else None
    return {
        "case": int(case_ref["case"]), "h0_over_D": case_ref["h0_over_D"],
        "V_i_measured": case_ref["V_i_m_per_s"], "V_i_model": v_i, "V_i_error_pct": err(v_i, case_ref["V_i_m_per_s"]),
        "Re_I_measured": case_ref["Re_I"], "Re_I_model": re_1, "Re_I_error_pct": err(re_1, case_ref["Re_I"]),
        "Re_II_measured": case_ref["Re_II"], "Re_II_model": re_2, "Re_II_error_pct": err(re_2, case_ref["Re_II"]),
        "St_I_model": first["St"] if first else None,
        "restitution_1": summary["rebounds"][0]["restitution"] if summary["rebounds"] else None,
        "status": summary["status"], "wall_time_s": summary["wall_time_s"],
    }


def markdown(rows: list[dict], model: str) -> str:
    def f(x, fmt):
        return "-" if x is None else format(x, fmt)

    lines = [f"| case | h0/D | V_i measured | V_i {model} | error | Re_I meas. | Re_I {model} | Re_II meas. | "
             f"Re_II {model} | error | e_1 {model} | wall time |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['h0_over_D']:.2f} | {r['V_i_measured']:.3f} | {f(r['V_i_model'], '.3f')} | "
            f"{f(r['V_i_error_pct'], '+.1f')} % | {r['Re_I_measured']:.0f} | {f(r['Re_I_model'], '.1f')} | "
            f"{r['Re_II_measured']:.0f} | {f(r['Re_II_model'], '.1f')} | {f(r['Re_II_error_pct'], '+.1f')} % | "
            f"{f(r['restitution_1'], '.3f')} | {r['wall_time_s']:.1f} s |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", default="ode")
    parser.add_argument("--cases", default="1,2,3,4,5,6,7")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--force", action="store_true", help="re-run cases that already have a summary")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    overrides = dict(scene.parse_override(text) for text in args.overrides)
    out = args.out or Path("results") / f"table2-{args.model}"
    measured = {int(r["case"]): r for r in reference.table("li2011_table2_experiments")}
    start = time.perf_counter()
    rows = [row(measured[c], run_case(c, args.model, out, overrides, args.force, comm))
            for c in (int(c) for c in args.cases.split(","))]
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        (out / "table2.md").write_text(markdown(rows, args.model))
        record = json.dumps({
            "model": args.model, "overrides": overrides, "rows": rows, "ranks": comm.size, "commit": commit(),
            "date": time.strftime("%Y-%m-%d"), "machine": platform.node(), "wall_time_s": time.perf_counter() - start,
        }, indent=2) + "\n"
        (out / "table2.json").write_text(record)
        if len(rows) == 7:
            (Path(__file__).parent / "history" / f"{out.name}.json").write_text(record)
        print(markdown(rows, args.model))


if __name__ == "__main__":
    main()
