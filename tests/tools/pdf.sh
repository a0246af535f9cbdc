#!/usr/bin/env bash
# Compiles every study's LaTeX report to PDF (pdflatex, three passes for longtable widths and
# references) in OUT_DIR, and fails on a LaTeX error, an undefined reference, a missing file, or
# an overfull box wider than OVERFULL_PT (default 5 pt: text or a table running into the margin).
# Usage: tests/tools/pdf.sh REPORTS_DIR OUT_DIR
set -euo pipefail
reports=${1:-reports}
out=${2:-target/reports-pdf}
if ! command -v pdflatex >/dev/null; then
  echo "error: pdflatex not found (Debian: apt-get install texlive-latex-extra texlive-pictures texlive-science)" >&2
  exit 1
fi
overfull_pt=${OVERFULL_PT:-5}
mkdir -p "$out"
failed=0
count=0
for tex in "$reports"/*/*.tex; do
  [ -f "$tex" ] || continue
  study=$(basename "$(dirname "$tex")")
  work="$out/$study"
  rm -rf "$work" && mkdir -p "$work" && cp -r "$(dirname "$tex")"/. "$work"/
  ok=1
  for pass in 1 2 3; do
    if ! (cd "$work" && pdflatex -interaction=nonstopmode -halt-on-error "$study.tex" > build.log 2>&1); then ok=0; break; fi
  done
  if [ $ok = 0 ] || grep -qE 'undefined references|Reference .* undefined|File .* not found' "$work/build.log"; then
    echo "$tex: LaTeX failed (see $work/build.log):" >&2
    grep -E '^!|undefined|not found' "$work/build.log" | head -5 >&2 || true
    failed=1
  elif wide=$(grep -oE 'Overfull \\hbox \(([0-9.]+)pt too wide\)' "$work/build.log" | grep -oE '[0-9.]+' | awk -v max="$overfull_pt" '$1 > max' | sort -rn | head -1) && [ -n "$wide" ]; then
    echo "$tex: an overfull box ${wide} pt too wide (limit ${overfull_pt} pt; see $work/build.log):" >&2
    grep -E -A1 'Overfull \\[hv]box' "$work/build.log" | head -6 >&2 || true
    failed=1
  else
    count=$((count + 1))
  fi
done
echo "pdf: $count reports compiled into $out"
exit $failed
