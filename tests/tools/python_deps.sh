#!/usr/bin/env bash
# What the external-algorithm tests and the committed external study need besides Rust: python3
# with numpy (data/algorithms/ekf_slam_py.py, tests/external/*.py). Run by `make test`, `make run`
# and `make report`. A missing numpy is installed with pip (into the user's site when not root);
# a missing python3 with apt, as build_tools.sh does for the compilers.
set -euo pipefail
. "$(dirname "$0")/apt_install.sh"

if ! command -v python3 >/dev/null; then
  apt_install "external algorithms (python3)" python3 python3-numpy
fi
python3 -c 'import tomllib' 2>/dev/null || {
  echo "error: $(python3 --version) has no tomllib: the external programs need Python 3.11 or newer" >&2
  exit 1
}
if ! python3 -c 'import numpy' 2>/dev/null; then
  echo "external algorithms: numpy missing, installing it with pip" >&2
  if python3 -m pip --version >/dev/null 2>&1; then
    user=(); [ "$(id -u)" -ne 0 ] && user=(--user)
    python3 -m pip install -q "${user[@]}" numpy >&2 || python3 -m pip install -q "${user[@]}" --break-system-packages numpy >&2
  else
    apt_install "external algorithms (numpy)" python3-numpy
  fi
  python3 -c 'import numpy' || { echo "error: numpy could not be installed for $(command -v python3)" >&2; exit 1; }
fi
