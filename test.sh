#!/usr/bin/env bash
# The test command (what CI runs after fmt and clippy): the Rust suite, then the Python package
# built with pip into a virtual environment under target/ and its pytest suite.
#
#   ./test.sh                 # everything
#   ./test.sh --test cli      # extra arguments go to `cargo test`
#   PUMPCYL_SKIP_RUST=1 ./test.sh   # the Python part only
#
# A test whose tool is missing here (GNU Octave, Chromium, python-control, FMPy, Dask) skips, and the
# last line says which and what installs them, or `skipped: none`. Under CI (`CI` set) nothing
# skips: a missing tool is a failure.
set -euo pipefail
cd "$(dirname "$0")"

# The skip log: a line `test<TAB>tool<TAB>install command` per skipped test, appended by
# tests/common/skip.rs and python/tests/conftest.py (`test<TAB>reason<TAB>` for other skips).
# skip_summary LOG prints the one line that sums it up, e.g.
#   skipped: 5 tests — 4 need octave and octave-control (apt-get install octave octave-control), 1 needs chromium (apt-get install chromium)
skip_summary() {
    if [ ! -s "$1" ]; then
        echo "skipped: none"
        return
    fi
    LC_ALL=C awk -F '\t' '
        # a before b: more tests, then a missing tool before another reason, then by name
        function before(a, b) {
            if (n[a] != n[b]) return n[a] > n[b]
            if ((a ~ /\t$/) != (b ~ /\t$/)) return b ~ /\t$/
            return a < b
        }
        NF == 0 || seen[$1]++ { next }
        {
            key = ($2 == "" ? "an unknown reason" : $2) "\t" $3
            if (!(key in n)) keys[++k] = key
            n[key]++
            total++
        }
        END {
            if (total == 0) { print "skipped: none"; exit }
            for (i = 2; i <= k; i++)
                for (j = i; j > 1 && before(keys[j], keys[j-1]); j--) {
                    t = keys[j]; keys[j] = keys[j-1]; keys[j-1] = t
                }
            line = "skipped: " total " test" (total == 1 ? "" : "s") " —"
            for (i = 1; i <= k; i++) {
                split(keys[i], f, "\t")
                c = n[keys[i]]
                if (f[2] != "") part = c " need" (c == 1 ? "s " : " ") f[1] " (" f[2] ")"
                else part = c " because " f[1]
                line = line (i == 1 ? " " : ", ") part
            }
            print line
        }' "$1"
}

# PUMPCYL_SUMMARIZE_SKIPS=LOG ./test.sh: only that line, for LOG (tests/skips.rs checks it).
if [ -n "${PUMPCYL_SUMMARIZE_SKIPS:-}" ]; then
    skip_summary "$PUMPCYL_SUMMARIZE_SKIPS"
    exit 0
fi

mkdir -p target
export PUMPCYL_SKIP_LOG="$PWD/target/skipped-tests.txt"
rm -f "$PUMPCYL_SKIP_LOG"
# the summary is the last line, whether the tests passed or not
trap 'status=$?; skip_summary "$PUMPCYL_SKIP_LOG"; exit "$status"' EXIT

# The Python side in the background while the Rust tests build and run: the test dependencies
# from the package registry (downloading and unpacking, little CPU), then the extension. Its
# build (maturin, dev profile) reuses the compiled dependencies of `cargo test` (they are
# optimised, see Cargo.toml): it waits for the build folder while `cargo test` compiles, then
# compiles PyO3, numpy and the bindings while the Rust tests run. A release wheel is
# `pip install ./python` without MATURIN_PEP517_ARGS.
VENV=target/py-venv
PIP_LOG=target/py-venv-pip.log
(
    if [ ! -x "$VENV/bin/python" ]; then python3 -m venv "$VENV"; fi
    "$VENV/bin/python" -m pip install -q --disable-pip-version-check maturin numpy pytest control fmpy mpmath dask distributed pandas playwright
    echo "== pip install ./python (maturin, dev profile)"
    PATH="$PWD/$VENV/bin:$PATH" MATURIN_PEP517_ARGS="--profile dev" "$VENV/bin/python" -m pip install -q \
        --disable-pip-version-check --no-build-isolation --force-reinstall --no-deps ./python
) > "$PIP_LOG" 2>&1 &
PIP_PID=$!
echo "== python3 -m venv $VENV; pip install maturin numpy pytest control fmpy mpmath dask distributed pandas playwright, then pip install ./python (in the background: $PIP_LOG)"

if [ -z "${PUMPCYL_SKIP_RUST:-}" ]; then
    # every crate of the workspace, the Python extension's too, from the registry where this
    # machine has not downloaded them yet (a few seconds)
    echo "== cargo fetch --locked"
    cargo fetch --locked
    echo "== cargo test --locked $*"
    if ! cargo test --locked "$@"; then
        wait "$PIP_PID" || true
        exit 1
    fi
fi

if ! wait "$PIP_PID"; then
    cat "$PIP_LOG" >&2
    echo "error: the Python test dependencies (the package registry) or the extension's build failed" >&2
    exit 1
fi

echo "== pytest -rs python/tests"
"$VENV/bin/python" -m pytest python/tests -q -rs
