"""An external scan matcher that estimates each pair's pose change as its initial guess (the
odometry increment): slamlab's test that pairs go out and per-match estimates come back through
the protocol (docs/src/guide/external-algorithms.md) and are chained like a built-in matcher's.

Usage: echo_matcher.py INPUT_DIR OUTPUT_DIR
"""
import sys

inp, out = sys.argv[1], sys.argv[2]
with open(f"{inp}/pairs.txt") as f, open(f"{out}/matches.txt", "w") as g:
    for line in f:
        if line.startswith("#") or not line.strip():
            continue
        ref, cur, x, y, th = line.split()
        g.write(f"{ref} {cur} {x} {y} {th}\n")
