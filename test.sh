#!/usr/bin/env bash
# The test command (what CI runs after fmt and clippy): the Rust suite, then the Python package
# built with pip into a virtual environment under target/ and its pytest suite.
#
#   ./test.sh                 # everything
#   ./test.sh --test cli      # extra arguments go to `cargo test`
#   PUMPCYL_SKIP_RUST=1 ./test.sh   # the Python part only
set -euo pipefail
cd "$(dirname "$0")"

if [ -z "${PUMPCYL_SKIP_RUST:-}" ]; then
    echo "== cargo test --locked $*"
    cargo test --locked "$@"
fi

VENV=target/py-venv
if [ ! -x "$VENV/bin/python" ]; then
    echo "== python3 -m venv $VENV"
    python3 -m venv "$VENV"
fi
echo "== pip install maturin numpy pytest control (the package registry)"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check maturin numpy pytest control

# The dev profile reuses the compiled dependencies of `cargo test` (they are optimised, see
# Cargo.toml); a release wheel is `pip install ./python` without MATURIN_PEP517_ARGS.
echo "== pip install ./python (maturin, dev profile)"
PATH="$PWD/$VENV/bin:$PATH" MATURIN_PEP517_ARGS="--profile dev" "$VENV/bin/python" -m pip install -q \
    --disable-pip-version-check --no-build-isolation --force-reinstall --no-deps ./python

echo "== pytest python/tests"
"$VENV/bin/python" -m pytest python/tests -q
