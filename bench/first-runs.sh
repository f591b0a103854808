#!/usr/bin/env bash
# A newcomer's first runs, timed (README, "First runs"): a fresh clone of this checkout's HEAD
# in a temporary folder, an empty cargo home (every crate fetched from the registry), no target
# folder, no pip cache; then the README's two commands and `pip install ./python`.
#
#   bench/first-runs.sh            # prints one line per command: wall and CPU time
#   KEEP=1 bench/first-runs.sh     # keeps the temporary folder and says where it is
#
# The toolchain stays rustup's; Debian's chromium, octave and octave-control are what .ci/run
# installs (without them ./test.sh skips those tests and says so).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
work="$(mktemp -d)"
[ -n "${KEEP:-}" ] || trap 'rm -rf "$work"' EXIT
git clone -q "$here" "$work/pumpcyl"
cd "$work/pumpcyl"
export CARGO_HOME="$work/cargo-home" PIP_NO_CACHE_DIR=1 PATH="$HOME/.cargo/bin:$PATH"
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), load $(cut -d' ' -f1-3 /proc/loadavg)"

# `label: wall, CPU` of the command after it (its children included) into $work/time.txt
timed() {
    local label="$1"
    shift
    /usr/bin/time -f "$label: %e s wall, %U s user + %S s system CPU" -o "$work/time.txt" "$@"
}

# 1. cargo run --release -- reproduce: when its first progress line appears, and in all
start=$(date +%s.%N)
timed "cargo run --release -- reproduce (build and run)" cargo run -q --release --locked -- reproduce --out "$work/reproduce" 2>&1 >/dev/null |
    while IFS= read -r line; do
        case "$line" in
        "[1/"*) echo "first progress line after $(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.0f", b - a }') s: $line" ;;
        esac
    done
cat "$work/time.txt"

# 2. the test command
if ! timed "./test.sh" ./test.sh >"$work/test.log" 2>&1; then
    tail -30 "$work/test.log"
    exit 1
fi
cat "$work/time.txt"
tail -1 "$work/test.log"

# 3. the Python package as a user installs it (release build), into a new virtual environment
python3 -m venv "$work/venv"
timed "pip install ./python (release)" "$work/venv/bin/pip" install -q ./python
cat "$work/time.txt"
