#!/usr/bin/env python3
"""Peer benchmark, the fair peer: the article's §2.4 grids in vectorised numpy and scipy.

The same 6817 candidates, records, model (peer_model.py, batched) and cost as peer_grid.py,
written as an engineer who knows numpy would write it: every candidate's closed loop at once as
a (6817, 10, 10) array, one exact zero-order-hold discretisation per candidate with
`scipy.linalg.expm` of the block matrix [[A, B], [0, 0]]·dt (stacked: one call), then the
recursion x[k+1] = Φ x[k] + Γ u[k] over the record's samples for all candidates together (one
batched matrix-vector product per sample). This is the model pumpcyl simulates
(docs/simulation.md#exact-zero-order-hold), so the costs agree with `pumpcyl simulate`.

Only the candidate evaluation is timed (assembly, expm, recursion, cost), not imports or file
reading. numpy and scipy run it on one core here (no threaded BLAS call is involved: the
products are 10x10 and stacked); `--repeat` runs it several times and reports the median
(the first run also pays for scipy's lazy set-up) and each time.

`--check PUMPCYL.json` (the output of `pumpcyl identify bench/peer/experiment.toml --json
--no-refine`) compares the two sides: the cost of each of pumpcyl's top candidates recomputed
here, and the number of candidates of each grid below pumpcyl's threshold (0.25 mm²).

Prints JSON: candidates_evaluated, seconds (the median of the repeats), seconds_all, best,
cost_at_article_truth_mm2, non_finite_cost_candidates, numpy_version, scipy_version, and
check with --check.
"""

import argparse
import json
import os
import statistics
import sys
import time

import numpy as np
import scipy
from scipy.linalg import expm

from peer_grid import HERE, TOTAL, first_grid, load_experiment, refined_grid
from peer_model import N, X, chamber_leakages, closed_loop


def zoh_batch(a, b, dt):
    """Φ (..., n, n) and Γ (..., n) of the exact ZOH of x' = A x + B u, one expm per model."""
    n = a.shape[-1]
    m = np.zeros(a.shape[:-2] + (n + 1, n + 1))
    m[..., :n, :n] = a * dt
    m[..., :n, n:] = b * dt
    e = expm(m)
    return e[..., :n, :n], e[..., :n, n]


def costs(cands, standstill, datasets):
    """The cost (mm²) of every candidate (rows of beta_bar, b, c12): the mean over the datasets
    of the position MSE over the fit window; +inf where the simulation overflows."""
    beta, b, c12 = cands[:, 0], cands[:, 1], cands[:, 2]
    c1, c2 = chamber_leakages(c12, **standstill)
    total = np.zeros(len(cands))
    for d in datasets:
        dt = np.diff(d["t"])
        if not np.allclose(dt, dt[0], rtol=1e-9, atol=0.0):
            sys.exit(f"{d['file']}: the vectorised peer needs a uniform time step")
        a, bm, _, _ = closed_loop(beta, b, c12, d["mass"], d["kp"], c1, c2)
        phi, gamma = zoh_batch(a, bm, dt[0])
        x = np.zeros((len(cands), N))
        y = np.empty((len(cands), d["t"].size))
        for k, uk in enumerate(d["u"]):
            y[:, k] = x[:, X]
            x = np.einsum("nij,nj->ni", phi, x) + gamma * uk
        err = (d["x0_mm"] + 1e3 * y - d["meas"])[:, d["window"]]
        total += np.mean(err * err, axis=1)
    total /= len(datasets)
    return np.where(np.isfinite(total), total, np.inf)


def check(path, grids, cost, standstill, datasets):
    """How pumpcyl's identify JSON at `path` agrees with the costs computed here."""
    with open(path) as f:
        pc = json.load(f)
    top = pc["top"]
    cands = np.array([[t["beta_bar"], t["viscous_friction_ns_per_m"], t["c12_m5_per_ns"]]
                      for t in top])
    ours = costs(cands, standstill, datasets)
    theirs = np.array([t["cost_mm2"] for t in top])
    counts = []
    for name, stage in zip(("first", "refined"), pc["stages"]):
        in_grid = np.array([g == name for g, _ in grids])
        counts.append({
            "grid": name,
            "threshold_mm2": stage["threshold_mm2"],
            "pumpcyl_below": stage["threshold_count"],
            "numpy_below": int(np.sum(cost[in_grid] < stage["threshold_mm2"])),
        })
    return {
        "top_candidates_compared": len(top),
        "top_cost_max_relative_difference": float(np.max(np.abs(ours / theirs - 1.0))),
        "same_best": bool(np.allclose(cands[0], [grids[int(np.argmin(cost))][1]], rtol=1e-12)),
        "below_threshold": counts,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--experiment", default=os.path.join(HERE, "experiment.toml"))
    ap.add_argument("--repeat", type=int, default=5, help="timed runs (the median is reported)")
    ap.add_argument("--check", metavar="PUMPCYL_JSON",
                    help="compare with `pumpcyl identify ... --json --no-refine` output")
    args = ap.parse_args()

    standstill, datasets = load_experiment(args.experiment)
    grids = [("first", c) for c in first_grid()] + [("refined", c) for c in refined_grid()]
    assert len(grids) == TOTAL
    cands = np.array([c for _, c in grids])

    times = []
    with np.errstate(all="ignore"):  # fast-diverging candidates overflow; they cost +inf
        for _ in range(max(args.repeat, 1)):
            t0 = time.perf_counter()
            cost = costs(cands, standstill, datasets)
            times.append(time.perf_counter() - t0)
        truth = costs(np.array([[165.0, 100.0, 1.2e-10]]), standstill, datasets)[0]
        checked = args.check and check(args.check, grids, cost, standstill, datasets)

    ib = int(np.argmin(cost))
    grid, (beta, b, c12) = grids[ib]
    c1, c2 = chamber_leakages(c12, **standstill)
    out = {
        "candidates_evaluated": int(cands.shape[0]),
        "seconds": statistics.median(times),
        "seconds_all": times,
        "best": {
            "grid": grid,
            "beta_bar": beta,
            "b_ns_per_m": b,
            "c12_m5_per_ns": c12,
            "c1_m5_per_ns": float(c1),
            "c2_m5_per_ns": float(c2),
            "cost_mm2": float(cost[ib]),
        },
        "cost_at_article_truth_mm2": float(truth),
        "non_finite_cost_candidates": int(np.sum(~np.isfinite(cost))),
        "input_interpolation": "zero-order hold (exact, scipy.linalg.expm of [[A, B], [0, 0]] dt)",
        "numpy_version": np.__version__,
        "scipy_version": scipy.__version__,
        "python_version": sys.version.split()[0],
    }
    if checked:
        out["check"] = checked
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
