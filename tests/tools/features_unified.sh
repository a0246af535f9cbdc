#!/usr/bin/env bash
# Fails when `cargo test`/`cargo bench` would resolve different features for a dependency than
# `cargo build --release` does: cargo then compiles that dependency (and everything above it,
# polars included) a second time. The fix is to pin the feature in Cargo.toml's [dependencies]
# (see the comment there).
set -euo pipefail
cd "$(dirname "$0")/../.."
target=$(rustc -vV | sed -n 's/^host: //p')
tree() { cargo tree --locked --offline --prefix none --target "$target" -f '{p} [{f}]' "$@" | sed 's/ (\*)$//' | sort -u; }
normal=$(tree -e no-dev)
with_dev=$(tree)
# Every crate of the normal build must appear with the same features when dev-dependencies join.
drift=$(comm -23 <(echo "$normal") <(echo "$with_dev"))
if [ -n "$drift" ]; then
  echo "features_unified: these dependencies get other features in test/bench builds, so make test would compile them (and polars) again:" >&2
  echo "$drift" >&2
  echo "with dev-dependencies:" >&2
  comm -13 <(echo "$normal") <(echo "$with_dev") | grep -F -f <(echo "$drift" | awk '{print $1" "$2" "}') >&2 || true
  exit 1
fi
echo "features_unified: the release, test and bench builds share every dependency build"
