#!/usr/bin/env bash
# Peak memory of `slamlab run` on studies of 1 000 and 4 000 dead-reckoning runs on Bigloop2
# (each run's results about 1.2 MB in memory): part of `make bench`. A study keeps its plan and
# each run's row; the runs' traces go through the cache. Usage: memory_bench.sh BIN (from the
# repository root; needs GNU time at /usr/bin/time).
set -euo pipefail
bin=${1:?usage: memory_bench.sh BIN}
[ -x /usr/bin/time ] || { echo "memory_bench: /usr/bin/time (GNU time) is needed"; exit 0; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for n in 1000 4000; do
  printf 'id = "mem%d"\ntitle = "Memory: %d dead-reckoning runs"\nseed = 3\nreplicates = %d\nmaps = ["bigloop2"]\nalgorithms = ["odometry"]\n' \
    "$n" "$n" "$n" > "$tmp/mem$n.toml"
  /usr/bin/time -f "%e %M" -o "$tmp/time" "$bin" run --quiet --results "$tmp/results" --cache "$tmp/cache" "$tmp/mem$n.toml" >/dev/null
  read -r secs kb < "$tmp/time"
  traces=$(stat -c %s "$tmp/results/mem$n/traces.parquet")
  printf 'study memory: %d runs computed and written in %.1f s, peak %d MB (traces.parquet %d MB)\n' \
    "$n" "$secs" $((kb / 1024)) $((traces / 1024 / 1024))
  rm -rf "$tmp/results" "$tmp/cache"
done
