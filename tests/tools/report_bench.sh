#!/usr/bin/env bash
# Times a warm `make report` (issue 29 item 4): `slamlab run` on every committed study, all cached,
# then `slamlab report`, on this checkout's results, three times; prints each step's median wall
# time. Needs a completed `make report` (results and cache in data/); skips with a message
# otherwise. Part of `make bench`. Usage: report_bench.sh BIN
set -euo pipefail
bin=${1:?usage: report_bench.sh BIN}
if [ ! -d data/results ] || [ -z "$(ls -A data/results 2>/dev/null)" ]; then
  echo "warm report: skipped (no data/results: run \`make report\` first)"
  exit 0
fi
now() { date +%s.%N; }
runs=(); reports=()
for _ in 1 2 3; do
  a=$(now); "$bin" run experiments/*.toml >/dev/null 2>&1 || true
  b=$(now); "$bin" report --specs experiments >/dev/null 2>&1
  c=$(now)
  runs+=("$(awk -v a="$a" -v b="$b" 'BEGIN { print b - a }')")
  reports+=("$(awk -v a="$b" -v b="$c" 'BEGIN { print b - a }')")
done
median() { printf '%s\n' "$@" | sort -g | sed -n 2p; }
studies=$(ls experiments/*.toml | wc -l)
awk -v r="$(median "${runs[@]}")" -v p="$(median "${reports[@]}")" -v n="$studies" 'BEGIN {
  printf "warm report (%d studies, median of 3): slamlab run %.2f s (all cached) + slamlab report %.2f s = %.2f s\n", n, r, p, r + p }'
