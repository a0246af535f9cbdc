#!/usr/bin/env bash
# Opens every report in headless Chromium (Debian's `chromium`, no network features) and fails on any
# console message (reports run no scripts), uncaught error or image that does not load; saves a screenshot of each page.
# Usage: tests/tools/check_html.sh REPORTS_DIR OUT_DIR
set -euo pipefail
reports=${1:-reports}
out=${2:-target/reports-html}
browser=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$browser" ]; then
  echo "error: chromium not found (Debian: apt-get install chromium)" >&2
  exit 1
fi
mkdir -p "$out"
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
flags=(--headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking
       --disable-component-update --disable-sync --user-data-dir="$profile" --enable-logging=stderr --v=0)
failed=0
pages=0
for page in "$reports"/index.html "$reports"/*/index.html; do
  [ -f "$page" ] || continue
  pages=$((pages + 1))
  name=$(basename "$(dirname "$page")")
  [ "$page" = "$reports/index.html" ] && name=index
  url="file://$(realpath "$page")"
  # Images: every <img src> must exist next to the page (reports inline their SVG, so there are few).
  for src in $(grep -o '<img [^>]*src="[^"]*"' "$page" | sed 's/.*src="\([^"]*\)"/\1/' || true); do
    case "$src" in data:*|http*) continue ;; esac
    if [ ! -f "$(dirname "$page")/$src" ]; then
      echo "$page: missing image $src" >&2
      failed=1
    fi
  done
  log=$("$browser" "${flags[@]}" --window-size=1280,4000 --screenshot="$out/$name.png" "$url" 2>&1 || true)
  if echo "$log" | grep -E 'CONSOLE[(:]|Uncaught|ERR_FILE_NOT_FOUND|Failed to load resource' | grep -v 'DevTools' >&2; then
    echo "$page: console errors or failed loads (above)" >&2
    failed=1
  fi
  [ -s "$out/$name.png" ] || { echo "$page: no screenshot" >&2; failed=1; }
done
echo "check-html: $pages pages opened in $(basename "$browser"), screenshots in $out"
exit $failed
