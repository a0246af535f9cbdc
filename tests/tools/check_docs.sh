#!/usr/bin/env bash
# `make check-docs`: the book's generated chapters are the ones the code generates now, every
# relative link of the README and the book resolves, the findings chapters restate no measured
# number (they include the reports' generated summaries), the README stays a five-minute read, and the
# book builds. Needs mdBook (MDBOOK, default `mdbook`; CI installs the pinned version).
set -euo pipefail
cd "$(dirname "$0")/../.."
MDBOOK=${MDBOOK:-mdbook}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
status=0

target/release/slamlab docs "$tmp/reference" > /dev/null
for f in "$tmp"/reference/*.md; do
  name=docs/src/reference/$(basename "$f")
  if ! cmp -s "$f" "$name"; then
    echo "$name: differs from what the code generates (run make docs and commit it)" >&2
    diff -u "$name" "$f" | head -20 >&2 || true
    status=1
  fi
done

python3 tests/tools/check_links.py README.md docs/src || status=1
python3 tests/tools/check_findings_numbers.py docs/src/findings || status=1

lines=$(wc -l < README.md)
if [ "$lines" -gt 250 ]; then echo "README.md: $lines lines, more than 250 (move the detail into the book)" >&2; status=1; fi

command -v "$MDBOOK" > /dev/null || { echo "mdbook not found (cargo install mdbook --version 0.4.52 --locked)" >&2; exit 1; }
"$MDBOOK" build docs -d "$tmp/book" > "$tmp/mdbook.log" 2>&1 || { cat "$tmp/mdbook.log" >&2; status=1; }
if grep -E "^\s*(\S+ )?(ERROR|WARN)" "$tmp/mdbook.log" >&2; then echo "mdbook: warnings or errors above" >&2; status=1; fi
[ "$status" -eq 0 ] && echo "docs: generated chapters current, links resolve, README $lines lines, the book builds"
exit "$status"
