#!/usr/bin/env bash
# Peer benchmark: `pumpcyl identify` against the same grid done with python-control.
#
#   bench/peer/run.sh                      # python side: 300 candidates, extrapolated to 6817
#   bench/peer/run.sh --max-candidates 0   # python side: all 6817 (slow)
#   bench/peer/run.sh --zoh                # python side: c2d ZOH instead of linear interpolation
#
# Extra arguments go to peer_grid.py. Works from any directory.
set -uo pipefail
export PYTHONDONTWRITEBYTECODE=1

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT" || exit 1
EXPERIMENT="bench/peer/experiment.toml"
TOTAL=6817
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

# json_get FILE FILTER: a value from a JSON file (jq if present, else python)
json_get() {
    if command -v jq >/dev/null 2>&1; then
        jq -r "$2 // empty" "$1"
    else
        python3 - "$1" "$2" <<'EOF'
import json, sys
v = json.load(open(sys.argv[1]))
for k in sys.argv[2].lstrip(".").split("."):
    v = v.get(k) if isinstance(v, dict) else None
print("" if v is None else v)
EOF
    fi
}

# calc EXPR: floating-point arithmetic
calc() { python3 -c "print($1)"; }

echo "== building pumpcyl (release)"
PUMPCYL_OK=1
if ! cargo build --release; then
    echo "!! cargo build --release failed; skipping the pumpcyl side" >&2
    PUMPCYL_OK=0
fi

PC_SECONDS="TBD"
PC_CANDIDATES=""
if [ "$PUMPCYL_OK" = 1 ]; then
    echo "== pumpcyl identify $EXPERIMENT --json --no-refine"
    if target/release/pumpcyl identify "$EXPERIMENT" --json --no-refine \
        >"$WORK/pumpcyl.json" 2>"$WORK/pumpcyl.err"; then
        PC_SECONDS="$(json_get "$WORK/pumpcyl.json" .seconds)"
        PC_CANDIDATES="$(json_get "$WORK/pumpcyl.json" .candidates_evaluated)"
        if [ -z "$PC_SECONDS" ]; then
            echo "!! pumpcyl identify printed no \"seconds\" key:" >&2
            cat "$WORK/pumpcyl.json" >&2
            PC_SECONDS="TBD"
        fi
    else
        echo "!! \`pumpcyl identify\` failed or does not exist yet (it is being written);" \
            "the pumpcyl side is TBD. Its message:" >&2
        sed 's/^/   /' "$WORK/pumpcyl.err" | head -20 >&2
    fi
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

# pumpcyl for 6817 candidates (scaled if it reports another count)
PC_6817="TBD"
RATIO="TBD"
if [ "$PC_SECONDS" != "TBD" ]; then
    PC_6817="$PC_SECONDS"
    if [ -n "$PC_CANDIDATES" ] && [ "$PC_CANDIDATES" != "$TOTAL" ]; then
        echo "!! pumpcyl evaluated $PC_CANDIDATES candidates, not $TOTAL: scaling its time" >&2
        PC_6817="$(calc "round($PC_SECONDS * $TOTAL / $PC_CANDIDATES, 3)")"
    fi
    RATIO="$(calc "round($PY_EXTRAP / $PC_6817, 1)")x"
fi

CPU="$(grep -m1 'model name' /proc/cpuinfo 2>/dev/null | cut -d: -f2- | sed 's/^ *//')"
echo
echo "== peer benchmark: the article's §2.4 grids ($TOTAL candidates, 2 datasets)"
printf '%-34s %s\n' "pumpcyl identify, $TOTAL cand. (s)" "$PC_6817${PC_CANDIDATES:+  (reported $PC_SECONDS s for $PC_CANDIDATES)}"
printf '%-34s %s\n' "python-control, $TOTAL cand. (s)" "$(calc "round($PY_EXTRAP, 1)")  (extrapolated from $PY_N candidates, $(calc "round($PY_PER * 1e3, 2)") ms each)"
printf '%-34s %s\n' "ratio python-control / pumpcyl" "$RATIO"
printf '%-34s %s\n' "machine" "$(nproc) CPUs, ${CPU:-unknown CPU}"
printf '%-34s %s\n' "python-control version" "$PY_VERSION"
printf '%-34s %s\n' "forced_response input" "$PY_INTERP"
