#!/usr/bin/env bash
# Install the Python peers used by benches/peers/peer_bench.py (Debian).
#
# Idempotent: does nothing when numpy, scipy and scikit-sparse's CHOLMOD
# binding already import.
#
# Notes from our measurements:
#   * scikit-sparse 0.5.0 does not build against Debian's SuiteSparse, so
#     the 0.4 series is pinned.
#   * Without an optimised BLAS, CHOLMOD was ~16x slower; libopenblas0-pthread
#     registers itself as the system libblas.so.3 / liblapack.so.3 provider
#     that Debian's CHOLMOD links against.
#
# Environment:
#   PYTHON  interpreter to install into (default: python3)
set -euo pipefail

PYTHON="${PYTHON:-python3}"

check() {
    "$PYTHON" -c "import numpy, scipy, sksparse.cholmod, pyamg" 2>/dev/null
}

if check; then
    echo "peers already installed:"
else
    if [ "$(id -u)" -eq 0 ]; then
        SUDO=""
    else
        SUDO="sudo"
    fi
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update
    $SUDO apt-get install -y libsuitesparse-dev libopenblas0-pthread
    "$PYTHON" -m pip install numpy scipy "scikit-sparse<0.5" "pyamg>=5.3"
    if ! check; then
        echo "error: peers still not importable after install" >&2
        exit 1
    fi
    echo "peers installed:"
fi

"$PYTHON" - <<'EOF'
import importlib.metadata as md
for pkg in ("numpy", "scipy", "scikit-sparse", "pyamg"):
    print(f"  {pkg} {md.version(pkg)}")
EOF
