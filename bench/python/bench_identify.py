#!/usr/bin/env python3
"""Benchmark: `pumpcyl.identify` on the article's grids against the same candidates simulated
with python-control in a Python loop (one run each; not a timed test).

Both sides fit the article's identification (the article §2.4.4) on the records in
data/article/ (identify.toml: identification.csv with Kp = 25, validation.csv with Kp = 20,
c1 and c2 from standstill.csv, the sum-pressure gain of its [set]): 3264 + 3553 = 6817
candidates (beta, b, c12), cost = mean over both records of the position MSE (mm^2) over the fit
window, the response taken as a deviation from the record's initial steady state.

- pumpcyl: `pumpcyl.identify("data/article/identify.toml", local_refinement=False)`, its own
  wall time (all cores, rayon; the GIL released).
- python-control: per candidate and record, the closed loop from `pumpcyl.state_space(rig,
  "closed")` (the same matrices), `control.ss`, `control.c2d(sys, dt, "zoh")` (the exact
  zero-order hold the records need; forced_response on a continuous system would interpolate
  the input linearly) and `control.forced_response`, on one core as a Python loop does.
  Python is slow, so --max-candidates (default 300) candidates spread evenly over both grids
  are timed and the per-candidate time is extrapolated to 6817 (0: all of them).

Checks before timing: python-control's cost at pumpcyl's best grid point equals pumpcyl's cost
there (to 1e-6 relative), so both sides compute the same thing.

Needs the package built in release for a fair number: `pip install ./python` (not the dev
profile `./test.sh` uses), and `pip install control`. Prints JSON and a short table.
"""

import argparse
import csv
import json
import os
import pathlib
import sys
import time

import numpy as np

import control
import pumpcyl

ROOT = pathlib.Path(__file__).resolve().parents[2]
ARTICLE = ROOT / "data" / "article"
sys.path.insert(0, str(ROOT / "bench" / "peer"))
from peer_model import chamber_leakages  # noqa: E402  (the article's c1, c2 from c12)

# (record, Kp, end of the fit window in s) as in data/article/identify.toml
DATASETS = (("identification.csv", 25.0, 2.7), ("validation.csv", 20.0, 2.4))
MASS_KG = 10593.0


def article_grids():
    first = dict(
        beta_bar=[float(b) for b in list(range(25, 251, 25)) + [300] + list(range(400, 601, 100))
                  + [800, 1000]],
        viscous_friction_ns_per_m=[float(b) for b in list(range(50, 251, 25)) + [300, 400, 500]],
        c12_m5_per_ns=list(np.logspace(-13, -9, 17)),
    )
    refined = dict(
        beta_bar=[float(b) for b in range(130, 221, 5)],
        viscous_friction_ns_per_m=[float(b) for b in range(100, 601, 50)],
        c12_m5_per_ns=list(np.linspace(0.8e-10, 2.4e-10, 17)),
    )
    return first, refined


def candidates(grid):
    return [(b, f, c) for b in grid["beta_bar"] for f in grid["viscous_friction_ns_per_m"]
            for c in grid["c12_m5_per_ns"]]


def read(name):
    with open(ARTICLE / name, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in ("time_s", "x_ref_mm", "x_mm")}


def records():
    out = []
    for name, kp, fit_end_s in DATASETS:
        r = read(name)
        changed = np.nonzero(r["x_ref_mm"] != r["x_ref_mm"][0])[0]
        k = max(int(changed[0]) if changed.size else len(r["time_s"]), 1)
        window = r["time_s"] <= fit_end_s
        out.append(dict(
            kp=kp, t=r["time_s"][window],
            u=(r["x_ref_mm"][window] - r["x_ref_mm"][:k].mean()) * 1e-3,
            meas=r["x_mm"][window] - r["x_mm"][:k].mean(),
        ))
    return out


def standstill():
    with open(ARTICLE / "standstill.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: float(np.mean([float(r[k]) for r in rows])) for k in ("w1_rpm", "w2_rpm", "p1_bar")}


def cost(cand, recs, still, base):
    beta, b, c12 = cand
    c1, c2 = chamber_leakages(c12, **still)
    total = 0.0
    for d in recs:
        rig = base.replace(beta_bar=beta, viscous_friction_ns_per_m=b, c12_m5_per_ns=c12,
                           c1_m5_per_ns=c1, c2_m5_per_ns=c2, kp=d["kp"], mass_kg=MASS_KG)
        sysd = control.c2d(control.ss(*pumpcyl.state_space(rig, "closed")),
                           d["t"][1] - d["t"][0], "zoh")
        y = control.forced_response(sysd, d["t"], d["u"]).outputs
        err = 1e3 * np.asarray(y) - d["meas"]
        total += float(np.mean(err * err))
    return total / len(recs) if np.isfinite(total) else float("inf")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--max-candidates", type=int, default=300,
                    help="python-control candidates, spread evenly over the 6817 (0: all)")
    args = ap.parse_args()

    first, refined = article_grids()
    t0 = time.perf_counter()
    r = pumpcyl.identify(str(ARTICLE / "identify.toml"), grid=first, refined_grid=refined,
                         local_refinement=False)
    pumpcyl_s = time.perf_counter() - t0
    total = r.candidates_evaluated
    assert total == 6817, total

    base, recs, still = pumpcyl.Rig(), records(), standstill()
    best = (r.beta_bar, r.viscous_friction_ns_per_m, r.c12_m5_per_ns)
    with np.errstate(all="ignore"):
        check = cost(best, recs, still, base)
    agree = abs(check / r.cost_mm2 - 1.0) < 1e-6
    if not agree:
        print(f"!! python-control's cost at pumpcyl's best {check} != pumpcyl's {r.cost_mm2}",
              file=sys.stderr)

    every = candidates(first) + candidates(refined)
    n = args.max_candidates
    idx = (np.arange(len(every)) if n <= 0 or n >= len(every)
           else np.unique(np.round(np.linspace(0, len(every) - 1, n)).astype(int)))
    with np.errstate(all="ignore"):  # unstable candidates overflow: they cost +inf
        t0 = time.perf_counter()
        for i in idx:
            cost(every[i], recs, still, base)
        python_s = time.perf_counter() - t0
    per = python_s / len(idx)
    out = dict(
        candidates=total,
        pumpcyl_seconds=r.seconds,
        pumpcyl_seconds_with_call=pumpcyl_s,
        pumpcyl_best=dict(beta_bar=r.beta_bar, viscous_friction_ns_per_m=r.viscous_friction_ns_per_m,
                          c12_m5_per_ns=r.c12_m5_per_ns, cost_mm2=r.cost_mm2),
        python_control_cost_at_that_point=check,
        costs_agree=agree,
        python_control_candidates_timed=int(len(idx)),
        python_control_seconds=python_s,
        python_control_seconds_per_candidate=per,
        python_control_seconds_6817=per * total,
        extrapolated=bool(len(idx) < total),
        ratio=per * total / r.seconds,
        cpus=os.cpu_count(),
        python_control_version=control.__version__,
        numpy_version=np.__version__,
    )
    print(json.dumps(out, indent=2))
    print(f"\npumpcyl.identify, 6817 candidates: {r.seconds:.3f} s ({os.cpu_count()} CPUs)",
          file=sys.stderr)
    print(f"python-control loop, 6817 candidates: {per * total:.1f} s"
          f"{' (extrapolated from %d, %.2f ms each)' % (len(idx), per * 1e3) if len(idx) < total else ''}",
          file=sys.stderr)
    print(f"ratio: {out['ratio']:.0f}x", file=sys.stderr)
    return 0 if agree else 1


if __name__ == "__main__":
    sys.exit(main())
