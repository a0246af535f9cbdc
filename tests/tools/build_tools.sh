#!/usr/bin/env bash
# The build tools slamlab needs besides Rust, checked before any cargo build (make build, make
# test, make bench and .ci/run all call this one script):
#   - a C compiler and libc headers: polars' compression codecs (zstd, lz4) compile C code;
#   - cmake, make and a C++ compiler: the nlopt crate builds NLopt from source with CMake (whose
#     default project languages include C++).
# What is missing is installed with apt when we are root or sudo works without a password;
# otherwise the script stops at once with the exact command to run.
set -euo pipefail
. "$(dirname "$0")/apt_install.sh"

if ! command -v cargo >/dev/null; then
  echo "error: cargo not found: slamlab needs a Rust toolchain (1.87 or newer), e.g. from https://rustup.rs" >&2
  exit 1
fi

need=()
command -v cc >/dev/null || need+=(gcc libc6-dev)
command -v c++ >/dev/null || need+=(g++)
command -v make >/dev/null || need+=(make)
command -v cmake >/dev/null || need+=(cmake)
[ ${#need[@]} -eq 0 ] && exit 0

apt_install "build tools (C/C++ compilers, make and cmake build NLopt and polars' codecs)" "${need[@]}"
