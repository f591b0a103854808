"""The closed-loop LTI model of docs/model.md, in numpy, exactly as pumpcyl assembles it.

Shared by peer_grid.py (the benchmark) and make_records.py (the synthetic records).
SI units throughout; the embedded article rig (the article §2.1) is the only rig supported.

States, in pumpcyl's order: x, v, p1, p2, w1, w2, tau1, tau2, z1, z2.
"""

import math

import numpy as np

# --- the article §2.3.4, the embedded default rig (SI) -----------------------------------------
D1_PISTON = 0.063
D2_ROD = 0.036
A1 = math.pi * D1_PISTON**2 / 4.0
A2 = math.pi * (D1_PISTON**2 - D2_ROD**2) / 4.0
VL = 0.1272e-3
X0 = 0.345
X_MAX = 0.5
V1 = VL + A1 * X0
V2 = VL + A2 * (X_MAX - X0)
J1 = (1600.0 + 600.0) * 1e-6
J2 = (1600.0 + 34.0) * 1e-6
DISP1 = 6e-6 / (2.0 * math.pi)
DISP2 = 3.6e-6 / (2.0 * math.pi)
OMEGA_I = 1256.6
KM = 0.026
KFF = 0.0016
TAU_FF = 0.0012
K_SCALE = 314.1593
# normalised command per Pa: pumpcyl's reading of the article's "22" as percent of full command
# per bar, 0.22 per bar (docs/choices.md, "The sum-pressure gain"), the default rig's
# k_pres_per_bar, so that both sides of the benchmark simulate the same closed loop
K_PRES = 0.22 / 1e5
K_BETA = 1.4
ALPHA = (DISP1 / DISP2) * (A1 / A2 - 1.0)

PA_PER_BAR = 1e5
RAD_S_PER_RPM = 2.0 * math.pi / 60.0

N = 10
X, V, P1, P2, W1, W2, T1, T2, Z1, Z2 = range(N)


def chamber_leakages(c12, w1_rpm=-160.0, w2_rpm=245.0, p1_bar=3.95):
    """docs/identification.md#leakage-from-standstill: c1, c2 from the standstill record for a given c12."""
    w1 = w1_rpm * RAD_S_PER_RPM
    w2 = w2_rpm * RAD_S_PER_RPM
    p1 = p1_bar * PA_PER_BAR
    p2 = p1 * A1 / A2  # force balance p1 A1 - p2 A2 = 0 (F_ext = 0)
    c1 = (DISP1 * w1 + DISP2 * w2 - c12 * (p1 - p2)) / p1
    c2 = (-DISP1 * w1 + c12 * (p1 - p2)) / p2
    return c1, c2


def plant(beta_bar, b, c12, mass, c1, c2):
    """Plant A (..., 10, 10) and B (..., 10, 2; inputs w_ref1, w_ref2 in rad/s).

    The parameters may be numpy arrays of one shape (a batch of candidates, as peer_numpy.py
    uses): A and B then carry that shape in front. Scalars give one 10x10 A and 10x2 B.
    """
    shape = np.broadcast(beta_bar, b, c12, mass, c1, c2).shape
    beta = beta_bar * PA_PER_BAR
    a = np.zeros(shape + (N, N))
    bm = np.zeros(shape + (N, 2))
    # Newton
    a[..., X, V] = 1.0
    a[..., V, P1] = A1 / mass
    a[..., V, P2] = -A2 / mass
    a[..., V, V] = -b / mass
    # continuity
    k1 = beta / V1
    a[..., P1, W1] = k1 * DISP1
    a[..., P1, W2] = k1 * DISP2
    a[..., P1, V] = -k1 * A1
    a[..., P1, P1] = -k1 * (c1 + c12)
    a[..., P1, P2] = k1 * c12
    k2 = beta / V2
    a[..., P2, W1] = -k2 * DISP1
    a[..., P2, V] = k2 * A2
    a[..., P2, P2] = -k2 * (c2 + c12)
    a[..., P2, P1] = k2 * c12
    # motors: J w' = tau - load; current loop; P velocity loop + filtered feedforward torque
    kf = KFF / TAU_FF
    for i, (w, t, z, j) in enumerate(((W1, T1, Z1, J1), (W2, T2, Z2, J2))):
        a[..., w, t] = 1.0 / j
        a[..., t, t] = -OMEGA_I
        a[..., t, w] = -OMEGA_I * KM
        a[..., t, z] = -OMEGA_I * kf
        bm[..., t, i] = OMEGA_I * KM + OMEGA_I * kf
        a[..., z, z] = -1.0 / TAU_FF
        bm[..., z, i] = 1.0 / TAU_FF
    # load torques: J1 w1' = tau1 - D1 (p1 - p2), J2 w2' = tau2 - D2 p1
    a[..., W1, P1] = -DISP1 / J1
    a[..., W1, P2] = DISP1 / J1
    a[..., W2, P1] = -DISP2 / J2
    return a, bm


def controller(kp, sum_pressure=True):
    """w_ref = Kx x + Kr x_ref (rad/s). Returns Kx (2x10), Kr (2x1)."""
    kr = K_SCALE * kp * np.array([[1.0], [ALPHA]])
    kx = np.zeros((2, N))
    kx[:, X] = -kr[:, 0]
    if sum_pressure:
        split = np.array([1.0, -K_BETA])
        kx[:, P1] = K_SCALE * K_PRES * split
        kx[:, P2] = K_SCALE * K_PRES * split
    return kx, kr


def closed_loop(beta_bar, b, c12, mass, kp, c1, c2):
    """Closed loop x_ref (m, deviation) -> x (m): A, B, C, D."""
    a, bm = plant(beta_bar, b, c12, mass, c1, c2)
    kx, kr = controller(kp, sum_pressure=True)
    c = np.zeros((1, N))
    c[0, X] = 1.0
    return a + bm @ kx, bm @ kr, c, np.zeros((1, 1))


def open_loop(beta_bar, b, c12, mass, kp, c1, c2):
    """The open loop (docs/analysis.md#the-loop-that-is-analysed): position feedback removed, sum-pressure loop open; input e (m)."""
    a, bm = plant(beta_bar, b, c12, mass, c1, c2)
    kx, kr = controller(kp, sum_pressure=False)
    c = np.zeros((1, N))
    c[0, X] = 1.0
    return a, bm @ kr, c, np.zeros((1, 1))
