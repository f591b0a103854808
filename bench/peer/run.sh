#!/usr/bin/env bash
# Peer benchmark: `pumpcyl identify` against the same grid done in Python, two ways: a
# vectorised numpy/scipy peer (peer_numpy.py, all candidates at once) and a python-control loop
# (peer_grid.py, one candidate at a time). The same model, records and cost on every side:
# peer_numpy.py checks its costs against pumpcyl's before anything is quoted.
#
#   bench/peer/run.sh                      # python-control: 300 candidates, extrapolated to 6817
#   bench/peer/run.sh --max-candidates 0   # python-control: all 6817 (minutes)
#   bench/peer/run.sh --linear             # python-control on the continuous system (see README)
#   PUMPCYL_RUNS=9 bench/peer/run.sh       # pumpcyl identify runs (default 5)
#
# Extra arguments go to peer_grid.py. Works from any directory. The machine, its load average
# before and after, and the spread of the repeated runs are printed with the figures.
set -uo pipefail
export PYTHONDONTWRITEBYTECODE=1

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT" || exit 1
EXPERIMENT="bench/peer/experiment.toml"
TOTAL=6817
RUNS="${PUMPCYL_RUNS:-5}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

# json_get FILE KEY.PATH: a value from a JSON file
json_get() {
    python3 - "$1" "$2" <<'EOF'
import json, sys
v = json.load(open(sys.argv[1]))
for k in sys.argv[2].lstrip(".").split("."):
    v = v.get(k) if isinstance(v, dict) else None
print("" if v is None else v)
EOF
}

# calc EXPR: floating-point arithmetic
calc() { python3 -c "print($1)"; }

load() { cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || uptime; }
LOAD_BEFORE="$(load)"

echo "== building pumpcyl (release)"
PC_MIN="TBD"
if cargo build --release --locked; then
    # all cores, then one thread (rayon reads RAYON_NUM_THREADS)
    for threads in "" 1; do
        echo "== pumpcyl identify $EXPERIMENT --json --no-refine ($RUNS runs${threads:+, $threads thread})"
        for i in $(seq "$RUNS"); do
            if ! RAYON_NUM_THREADS="$threads" target/release/pumpcyl identify "$EXPERIMENT" \
                --json --no-refine >"$WORK/pumpcyl.json" 2>"$WORK/pumpcyl.err"; then
                echo "!! pumpcyl identify failed:" >&2
                sed 's/^/   /' "$WORK/pumpcyl.err" | head -20 >&2
                break 2
            fi
            json_get "$WORK/pumpcyl.json" .seconds >>"$WORK/pumpcyl$threads.seconds"
        done
    done
    if [ -s "$WORK/pumpcyl1.seconds" ]; then
        # spread: "median min max" of each
        spread() {
            python3 -c "
import statistics
s = sorted(float(x) for x in open('$1'))
print(f'{statistics.median(s):.4f} {s[0]:.4f} {s[-1]:.4f}')"
        }
        read -r PC_MED PC_MIN PC_MAX < <(spread "$WORK/pumpcyl.seconds")
        read -r PC1_MED PC1_MIN PC1_MAX < <(spread "$WORK/pumpcyl1.seconds")
        PC_N="$(json_get "$WORK/pumpcyl.json" .candidates_evaluated)"
        [ "$PC_N" = "$TOTAL" ] || echo "!! pumpcyl evaluated $PC_N candidates, not $TOTAL" >&2
    fi
else
    echo "!! cargo build --release failed; skipping the pumpcyl side" >&2
fi

echo "== python3 bench/peer/peer_numpy.py (one thread)"
NP_OK=1
CHECK=()
[ -s "$WORK/pumpcyl.json" ] && CHECK=(--check "$WORK/pumpcyl.json")
if ! OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \
    python3 bench/peer/peer_numpy.py "${CHECK[@]}" >"$WORK/numpy.json"; then
    echo "!! peer_numpy.py failed (numpy and scipy installed?)" >&2
    NP_OK=0
fi

echo "== python3 bench/peer/peer_grid.py $*"
if ! python3 bench/peer/peer_grid.py "$@" >"$WORK/peer.json"; then
    echo "!! peer_grid.py failed (is python-control installed? pip install control)" >&2
    exit 1
fi
PY_EXTRAP="$(json_get "$WORK/peer.json" .extrapolated_seconds_6817)"
PY_N="$(json_get "$WORK/peer.json" .candidates_evaluated)"
PY_PER="$(json_get "$WORK/peer.json" .seconds_per_candidate)"
PY_VERSION="$(json_get "$WORK/peer.json" .python_control_version)"
PY_INTERP="$(json_get "$WORK/peer.json" .input_interpolation)"
LOAD_AFTER="$(load)"

# ratio SECONDS: "N× (all cores), M× (one thread)" against pumpcyl's medians
ratio() {
    [ "$PC_MIN" = "TBD" ] && { echo "TBD"; return; }
    echo "$(calc "round($1 / $PC_MED)")x against all cores, $(calc "round($1 / $PC1_MED)")x thread for thread"
}
CPU="$(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1)"
echo
echo "== peer benchmark: the article's §2.4 grids ($TOTAL candidates, 2 records of 401 samples)"
printf '%-36s %s\n' "machine" "$(nproc) CPUs, ${CPU:-unknown CPU}"
printf '%-36s %s\n' "load average (1, 5, 15 min)" "before: $LOAD_BEFORE; after: $LOAD_AFTER"
if [ "$PC_MIN" != "TBD" ]; then
    printf '%-36s %s\n' "pumpcyl identify, all cores (s)" \
        "median $PC_MED, min $PC_MIN, max $PC_MAX over $RUNS runs"
    printf '%-36s %s\n' "pumpcyl identify, 1 thread (s)" \
        "median $PC1_MED, min $PC1_MIN, max $PC1_MAX over $RUNS runs"
fi
if [ "$NP_OK" = 1 ]; then
    NP_S="$(json_get "$WORK/numpy.json" .seconds)"
    NP_ALL="$(python3 -c "import json; print(', '.join(f'{s:.3f}' for s in json.load(open('$WORK/numpy.json'))['seconds_all']))")"
    printf '%-36s %s\n' "numpy/scipy vectorised, 1 thread (s)" "$(calc "round($NP_S, 3)") (median of $NP_ALL)"
fi
printf '%-36s %s\n' "python-control loop, 1 thread (s)" \
    "$(calc "round($PY_EXTRAP, 1)") (extrapolated from $PY_N candidates, $(calc "round($PY_PER * 1e3, 2)") ms each)"
[ "$NP_OK" = 1 ] && printf '%-36s %s\n' "ratio numpy / pumpcyl" "$(ratio "$NP_S")"
printf '%-36s %s\n' "ratio python-control / pumpcyl" "$(ratio "$PY_EXTRAP")"
printf '%-36s %s\n' "python-control version" "$PY_VERSION"
printf '%-36s %s\n' "python-control input" "$PY_INTERP"
if [ "$NP_OK" = 1 ] && [ ${#CHECK[@]} -gt 0 ]; then
    python3 - "$WORK/numpy.json" <<'EOF'
import json, sys
c = json.load(open(sys.argv[1]))["check"]
counts = "; ".join(f"{b['grid']} grid {b['pumpcyl_below']} vs {b['numpy_below']}"
                   for b in c["below_threshold"])
print(f"{'same costs (numpy vs pumpcyl)':36s} top {c['top_candidates_compared']} candidates "
      f"to {c['top_cost_max_relative_difference']:.1e} relative, same best: {c['same_best']}; "
      f"below 0.25 mm²: {counts}")
EOF
fi
