#!/usr/bin/env python3
"""Regenerate the peer benchmark's synthetic records ident.csv and valid.csv.

Both are a 5 mm step 340 -> 345 mm sampled at 100 Hz: 0.5 s at rest (t = 0.00 … 0.49 s),
the step at t = 0.50 s, then 3.5 s after it (last sample t = 4.00 s, 401 samples).
The response is the closed loop of docs/model.md (peer_model.py) at the article's truth
(beta = 165 bar, b = 100 N·s/m, c12 = 1.2e-10 m^5/(N·s); c1, c2 from docs/identification.md#leakage-from-standstill), simulated
exactly with a zero-order hold on the sampled reference (docs/simulation.md#exact-zero-order-hold: each sample holds until the
next), plus seeded Gaussian noise of 0.01 mm on x_mm (numpy default_rng(7); ident.csv draws
first, then valid.csv).

    python3 bench/peer/make_records.py          # writes next to this script
"""

import argparse
import os

import numpy as np
from scipy.linalg import expm

from peer_model import chamber_leakages, closed_loop

HERE = os.path.dirname(os.path.abspath(__file__))

TRUTH = {"beta_bar": 165.0, "b": 100.0, "c12": 1.2e-10}
RATE_HZ = 100.0
REST_S = 0.5
AFTER_S = 3.5
X_START_MM = 340.0
STEP_MM = 5.0
NOISE_MM = 0.01
SEED = 7
RECORDS = (("ident.csv", 25.0, 10593.0), ("valid.csv", 20.0, 10593.0))


def zoh_response(a, b, c, dt, u):
    """Exact ZOH simulation of x' = A x + B u, y = C x from rest."""
    n = a.shape[0]
    m = np.zeros((n + 1, n + 1))
    m[:n, :n] = a * dt
    m[:n, n:] = b * dt
    e = expm(m)
    ad, bd = e[:n, :n], e[:n, n:]
    x = np.zeros((n, 1))
    y = np.empty(len(u))
    for k, uk in enumerate(u):
        y[k] = (c @ x)[0, 0]
        x = ad @ x + bd * uk
    return y


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=HERE)
    args = ap.parse_args()

    n_rest = int(round(REST_S * RATE_HZ))
    n = n_rest + int(round(AFTER_S * RATE_HZ)) + 1
    t = np.arange(n) / RATE_HZ
    ref_dev_mm = np.where(np.arange(n) >= n_rest, STEP_MM, 0.0)
    c1, c2 = chamber_leakages(TRUTH["c12"])
    rng = np.random.default_rng(SEED)
    for name, kp, mass in RECORDS:
        a, b, c, _ = closed_loop(TRUTH["beta_bar"], TRUTH["b"], TRUTH["c12"], mass, kp, c1, c2)
        x_dev_m = zoh_response(a, b, c, 1.0 / RATE_HZ, ref_dev_mm * 1e-3)
        x_mm = X_START_MM + x_dev_m * 1e3 + rng.normal(0.0, NOISE_MM, n)
        path = os.path.join(args.out_dir, name)
        with open(path, "w", newline="\n") as f:
            f.write("time_s,x_ref_mm,x_mm\n")
            for tk, rk, xk in zip(t, X_START_MM + ref_dev_mm, x_mm):
                f.write(f"{tk:.6f},{rk:.6f},{xk:.6f}\n")
        print(f"wrote {path}: {n} samples, Kp = {kp}, m = {mass} kg, "
              f"x at end {x_mm[-1]:.3f} mm")


if __name__ == "__main__":
    main()
