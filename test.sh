#!/usr/bin/env bash
# The test command (what CI runs after fmt and clippy): the Rust suite, then the Python package
# built with pip into a virtual environment under target/ and its pytest suite.
#
#   ./test.sh                 # everything
#   ./test.sh --test cli      # extra arguments go to `cargo test`
#   PUMPCYL_SKIP_RUST=1 ./test.sh   # the Python part only
set -euo pipefail
cd "$(dirname "$0")"

# The Python test dependencies come from the package registry: fetched in the background while
# the Rust tests build and run (downloading and unpacking, little CPU; about 25 s of a fresh run).
VENV=target/py-venv
PIP_LOG=target/py-venv-pip.log
mkdir -p target
(
    if [ ! -x "$VENV/bin/python" ]; then python3 -m venv "$VENV"; fi
    "$VENV/bin/python" -m pip install -q --disable-pip-version-check maturin numpy pytest control fmpy
) > "$PIP_LOG" 2>&1 &
PIP_PID=$!
echo "== python3 -m venv $VENV; pip install maturin numpy pytest control fmpy (in the background: $PIP_LOG)"

if [ -z "${PUMPCYL_SKIP_RUST:-}" ]; then
    echo "== cargo test --locked $*"
    if ! cargo test --locked "$@"; then
        wait "$PIP_PID" || true
        exit 1
    fi
fi

if ! wait "$PIP_PID"; then
    cat "$PIP_LOG" >&2
    echo "error: pip install of the Python test dependencies failed (the package registry)" >&2
    exit 1
fi

# The dev profile reuses the compiled dependencies of `cargo test` (they are optimised, see
# Cargo.toml); a release wheel is `pip install ./python` without MATURIN_PEP517_ARGS.
echo "== pip install ./python (maturin, dev profile)"
PATH="$PWD/$VENV/bin:$PATH" MATURIN_PEP517_ARGS="--profile dev" "$VENV/bin/python" -m pip install -q \
    --disable-pip-version-check --no-build-isolation --force-reinstall --no-deps ./python

echo "== pytest python/tests"
"$VENV/bin/python" -m pytest python/tests -q
