#!/usr/bin/env bash
# One million candidates: `pumpcyl identify` on the peer benchmark's records (ident.csv,
# valid.csv) with a 100 × 100 × 100 first grid (β 25…1000 bar and b 50…600 N·s/m linear,
# c12 1e-13…1e-9 m⁵/(N·s) logarithmic) and a one-point second grid (the truth), without the
# local refinement. Prints pumpcyl's own `seconds`, the wall time, the peak resident memory of
# the process, the machine and its load average.
#
#   bench/peer/million.sh          # RUNS=3 by default
#   RUNS=5 bench/peer/million.sh
set -uo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT" || exit 1
RUNS="${RUNS:-3}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

cargo build --release --locked || exit 1
python3 - "$ROOT/bench/peer" >"$WORK/million.toml" <<'EOF'
import sys
import numpy as np
peer = sys.argv[1]
axis = lambda v: "[" + ", ".join(repr(float(x)) for x in v) + "]"
print(f"""# 100 x 100 x 100 candidates on the peer benchmark's records (bench/peer/million.sh)
[standstill]
w1_rpm = -160.0
w2_rpm = 245.0
p1_bar = 3.95

[[dataset]]
file = "{peer}/ident.csv"
kp = 25.0
mass_kg = 10593.0
fit_end_s = 3.7

[[dataset]]
file = "{peer}/valid.csv"
kp = 20.0
mass_kg = 10593.0
fit_end_s = 3.7

[grid]
beta_bar = {axis(np.linspace(25.0, 1000.0, 100))}
viscous_friction_ns_per_m = {axis(np.linspace(50.0, 600.0, 100))}
c12_m5_per_ns = {axis(np.logspace(-13, -9, 100))}

[refined_grid]
beta_bar = [165.0]
viscous_friction_ns_per_m = [100.0]
c12_m5_per_ns = [1.2e-10]
""")
EOF
[ -s "$WORK/million.toml" ] || { echo "!! could not write the experiment (numpy needed)" >&2; exit 1; }

CPU="$(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1)"
echo "machine: $(nproc) CPUs, ${CPU:-unknown CPU}; load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
for i in $(seq "$RUNS"); do
    /usr/bin/time -f "%e %M" -o "$WORK/time" target/release/pumpcyl identify "$WORK/million.toml" \
        --json --no-refine >"$WORK/out.json" || exit 1
    read -r wall rss_kb <"$WORK/time"
    python3 - "$WORK/out.json" "$wall" "$rss_kb" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"run: {d['candidates_evaluated']} candidates, pumpcyl seconds {d['seconds']:.2f}, "
      f"wall {float(sys.argv[2]):.2f} s, peak resident memory {int(sys.argv[3]) / 1024:.1f} MB, "
      f"best beta {d['beta_bar']} bar, b {d['viscous_friction_ns_per_m']} N·s/m, "
      f"c12 {d['c12_m5_per_ns']:.3g}")
EOF
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
