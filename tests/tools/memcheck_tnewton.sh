#!/usr/bin/env bash
# TNEWTON under valgrind's memcheck: one `ep-simultaneous` cell (laser σ = 2 cm at 1 m, no odometry
# noise), TNEWTON only, one replicate, its first 20 matches, on one thread. NLopt's PNET read memory
# it had never written (build/nlopt_patch.rs); this fails on any use of an uninitialised value.
# Usage: tests/tools/memcheck_tnewton.sh path/to/slamlab   (installs valgrind with apt when missing)
set -euo pipefail
. "$(dirname "$0")/apt_install.sh"
bin=${1:?usage: memcheck_tnewton.sh path/to/slamlab}
command -v valgrind >/dev/null || apt_install "valgrind (make memcheck)" valgrind

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
spec=experiments/ep-simultaneous.toml
# The study up to its claims, fixed (no sequential stages), with TNEWTON alone, one replicate, 20
# matches and the scan20 cell.
sed '/^\[\[claims\]\]/,$d' "$spec" \
  | sed '/^max_replicates = /d; /^\[sequential\]/,/^$/d' \
  | sed -E 's/^algorithms = .*/algorithms = ["tnewton"]/; s/^replicates = .*/replicates = 1/; s/^max_matches = .*/max_matches = 20/' \
  | sed -E 's/^labels = .*/labels = ["scan20"]/; s/^values = .*/values = { "odometry.k" = [0.0], "laser.range_sigma_m" = [0.02] }/' \
  | sed '/^\[report\]/,/^$/d' > "$tmp/ep-simultaneous.toml"
for want in 'algorithms = \["tnewton"\]' 'replicates = 1' 'max_matches = 20' 'labels = \["scan20"\]'; do
  grep -q "^$want" "$tmp/ep-simultaneous.toml" \
    || { echo "memcheck: $spec changed shape ($want not set): update $0" >&2; exit 1; }
done
for unwanted in 'max_replicates' '\[sequential\]'; do
  ! grep -q "^$unwanted" "$tmp/ep-simultaneous.toml" \
    || { echo "memcheck: $spec changed shape ($unwanted still set): update $0" >&2; exit 1; }
done

echo "memcheck: one TNEWTON run (20 matches) under valgrind --track-origins=yes; takes about 10 s"
valgrind --tool=memcheck --error-exitcode=3 --track-origins=yes --leak-check=no \
  --log-file="$tmp/valgrind.log" \
  "$bin" run -q -j 1 "$tmp/ep-simultaneous.toml" --results "$tmp/results" --cache "$tmp/cache" \
  && status=0 || status=$?
grep -E "ERROR SUMMARY" "$tmp/valgrind.log" | tail -1
if [ "$status" -ne 0 ]; then
  # The first error: its kind, its top frames and where the value came from.
  awk '/^==[0-9]+== (Conditional|Use of|Syscall|Invalid)/ {on=1; n=0}
       on && n < 8 {print; n++}
       on && /Uninitialised value was created/ {getline; print; getline; print; exit}' \
    "$tmp/valgrind.log" | cut -c1-200 >&2
  echo "memcheck: TNEWTON reads memory it has not written, or the run failed (exit $status)" >&2
  exit 1
fi
runs=$(python3 - "$tmp/results/ep-simultaneous/runs.parquet" <<'PY' 2>/dev/null || echo "?"
import sys, pyarrow.parquet as pq
t = pq.read_table(sys.argv[1]).to_pydict()
print(sum(1 for s in t["status"] if s == "ok"), "ok of", len(t["status"]))
PY
)
echo "memcheck: clean ($runs runs)"
