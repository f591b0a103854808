"""H1 = Pxy/Pxx and the coherence of a record by scipy.signal.csd and welch: the independent
reference of pumpcyl's Welch estimate (docs/identification.md#frequency-response-from-a-sweep).

Usage: python3 frf_scipy.py RECORD.csv NPERSEG  — prints JSON {freq_hz, re, im, coherence}
over every bin, Hann window, half overlap, each segment's mean removed."""

import json
import sys

import numpy as np
from scipy import signal


def main():
    path, nperseg = sys.argv[1], int(sys.argv[2])
    data = np.genfromtxt(path, delimiter=",", names=True)
    t, r, x = data["time_s"], data["x_ref_mm"], data["x_mm"]
    fs = (len(t) - 1) / (t[-1] - t[0])
    kw = dict(fs=fs, window="hann", nperseg=nperseg, noverlap=nperseg // 2, detrend="constant")
    f, prx = signal.csd(r, x, **kw)
    _, prr = signal.welch(r, **kw)
    _, pxx = signal.welch(x, **kw)
    h = prx / prr
    coherence = np.abs(prx) ** 2 / (prr * pxx)
    print(json.dumps({"freq_hz": f.tolist(), "re": h.real.tolist(), "im": h.imag.tolist(),
                      "coherence": coherence.tolist()}))


if __name__ == "__main__":
    main()
