#!/usr/bin/env bash
# Times `slamlab validate` (expanding and checking a plan) on FastSLAM grid sweeps of n × n points,
# n = 316 and 1000 (10⁵ and 10⁶ runs): part of `make bench`. Usage: plan_bench.sh BIN
set -euo pipefail
bin=${1:?usage: plan_bench.sh BIN}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for n in 316 1000; do
  id="grid$n"
  {
    printf 'id = "%s"\ntitle = "Plan benchmark: a %d x %d grid"\nseed = 1\nreplicates = 1\n' "$id" "$n" "$n"
    printf 'maps = ["recinto_basico"]\nalgorithms = ["fastslam1"]\n[[sweeps]]\nkind = "grid"\nvalues = { '
    printf '"odometry.k" = ['
    awk -v n="$n" 'BEGIN { for (i = 0; i < n; i++) printf "%s%.5f", (i ? ", " : ""), 0.001 + i * 1e-5 }'
    printf '], "features.dmax_m" = ['
    awk -v n="$n" 'BEGIN { for (i = 0; i < n; i++) printf "%s%.4f", (i ? ", " : ""), 0.01 + i * 1e-4 }'
    printf '] }\n'
  } > "$tmp/$id.toml"
  if [ -x /usr/bin/time ]; then
    /usr/bin/time -f "%e %M" -o "$tmp/time" "$bin" validate "$tmp/$id.toml" >/dev/null 2>"$tmp/err"
    read -r secs kb < "$tmp/time"
    printf 'plan: %d x %d grid (%d runs) expanded and checked in %.2f s, peak %d MB\n' \
      "$n" "$n" $((n * n)) "$secs" $((kb / 1024))
  else
    start=$(date +%s.%N)
    "$bin" validate "$tmp/$id.toml" >/dev/null 2>"$tmp/err"
    end=$(date +%s.%N)
    awk -v a="$start" -v b="$end" -v n="$n" 'BEGIN { printf "plan: %d x %d grid (%d runs) expanded and checked in %.2f s\n", n, n, n * n, b - a }'
  fi
done
