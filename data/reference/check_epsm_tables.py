#!/usr/bin/env python3
"""Checks epsm-tables.csv, the [EP] (E-PSM) Tables 2-5 transcribed from the write-up
`epsm-scan-matching.md` (§6), and re-derives numbers the write-up states about them.

    python3 data/reference/check_epsm_tables.py [--csv PATH] [--writeup PATH]

1. Structure: the header, the row count of each table, that every key
   (table, map, algorithm, cell, stat, metric) appears once, that each table is a full grid
   (every algorithm x metric x stat x cell it should have), and that every value is a
   non-negative finite number.
2. Derived numbers: the percentages, ratios, ranges and counts that the write-up states (§6
   "Derived" rows, §8 claims C1-C6, the Fig 16-19 captions, the Table 3 notes) are recomputed from
   the CSV. A wrong digit in the CSV almost always breaks one of them.
3. Second pass, when the write-up is available (default: ../shared/reference/epsm-scan-matching.md
   next to the repository, i.e. ../../../shared/reference/ from this file; skipped if absent): every
   group of 7 or 8 CSV values is written back as the markdown table row it came from and that
   exact line must appear under the right heading of the write-up.

Standard library only. Exit status 1 on any failure.
"""

import argparse
import csv
import math
import sys
from collections import Counter, defaultdict
from decimal import ROUND_HALF_UP, Decimal
from pathlib import Path

HERE = Path(__file__).resolve().parent
CSV_PATH = HERE / "epsm-tables.csv"
HEADER = ["table", "map", "algorithm", "cell", "stat", "metric", "value", "source_lines"]
CELLS = ["none", "odo1", "odo5", "odo10", "scan5", "scan20", "scan5_odo5", "scan20_odo10"]
CELLS7 = CELLS[:7]
MAPS5 = ["ep_rect_column", "ep_polygon", "ep_bigmap"]
T3_ALGS = ["psm", "epsm", "brute_force", "direct_l", "crs2", "isres", "mlsl_lds", "cobyla", "bobyqa", "sbplx",
           "slsqp", "lbfgs", "tnewton", "var2"]
METRICS5 = ["ax_mm", "ay_mm", "atheta_deg", "f", "time_s"]
# table -> (maps, algorithms, cells, stats, metrics, source_lines, rows)
EXPECTED = {
    "2": (["ep_rect_column"], ["psm", "epsm", "brute_force"], CELLS, ["mean", "max"], METRICS5, "L376-378", 240),
    "3": (["ep_rect_column"], T3_ALGS, CELLS7, ["mean"], ["f", "time_s"], "L420-423", 196),
    "4": (["ep_rect_column"], ["psm", "psm_original"], CELLS, ["mean"], ["f", "time_s", "evals"], "L432-435", 48),
    "5": (MAPS5, ["epsm", "crs2"], CELLS, ["mean"], METRICS5, "L530-538", 240),
}

failures = []
checks = 0


def check(ok, what):
    global checks
    checks += 1
    if not ok:
        failures.append(what)
        print(f"FAIL: {what}")


def pct(x):
    """Rounded to 0.1 (half up, as a reader rounds), for comparison with the write-up's percentages."""
    return float(Decimal(repr(x)).quantize(Decimal("0.1"), rounding=ROUND_HALF_UP))


def rounded_like(x, printed):
    """x (a full-precision printed value) rounded to the number of decimals `printed` shows."""
    places = len(printed.split(".")[1]) if "." in printed else 0
    return Decimal(x).quantize(Decimal(1).scaleb(-places), rounding=ROUND_HALF_UP) == Decimal(printed)


def load(path):
    with open(path, newline="") as f:
        text = f.read()
    check('"' not in text, "the file uses no quoting")
    check(text.isascii(), "the file is plain ASCII")
    rows = list(csv.reader(text.splitlines()))
    check(rows[0] == HEADER, f"header is {rows[0]}, expected {HEADER}")
    return [dict(zip(HEADER, r)) for r in rows[1:]]


def structure(rows):
    counts = Counter(r["table"] for r in rows)
    for t, (maps, algs, cells, stats, metrics, lines, n) in EXPECTED.items():
        check(counts[t] == n, f"table {t}: {counts[t]} rows, expected {n}")
        got = {(r["map"], r["algorithm"], r["cell"], r["stat"], r["metric"]) for r in rows if r["table"] == t}
        want = {(m, a, c, s, x) for m in maps for a in algs for c in cells for s in stats for x in metrics}
        check(got == want, f"table {t}: keys differ from the full grid: missing {sorted(want - got)[:5]}, extra {sorted(got - want)[:5]}")
        bad_lines = {r["source_lines"] for r in rows if r["table"] == t} - {lines}
        check(not bad_lines, f"table {t}: source_lines {bad_lines}, expected {lines}")
    check(set(counts) == set(EXPECTED), f"unexpected tables {set(counts) - set(EXPECTED)}")
    check(len(rows) == 724, f"{len(rows)} rows, expected 724")
    keys = Counter((r["table"], r["map"], r["algorithm"], r["cell"], r["stat"], r["metric"]) for r in rows)
    dups = [k for k, n in keys.items() if n > 1]
    check(not dups, f"duplicate keys: {dups[:5]}")
    for r in rows:
        try:
            v = float(r["value"])
            check(math.isfinite(v) and v >= 0, f"value {r['value']!r} is not a non-negative number: {r}")
        except ValueError:
            check(False, f"value {r['value']!r} is not a number: {r}")
    return counts


def derived(rows):
    S = {(r["table"], r["map"], r["algorithm"], r["cell"], r["stat"], r["metric"]): r["value"] for r in rows}

    def v(t, alg, cell, metric, stat="mean", m="ep_rect_column"):
        return float(S[(t, m, alg, cell, stat, metric)])

    def s(t, alg, cell, metric, stat="mean", m="ep_rect_column"):
        return S[(t, m, alg, cell, stat, metric)]

    # --- Table 2 "Derived" block (write-up §6.2): 1 - E-PSM/Diosi of the means, and time ratios.
    red = {
        "ax_mm": [83.6, 94.1, 90.4, 67.1, 71.9, 52.7, 70.8, 44.7],
        "ay_mm": [90.2, 94.2, 83.5, 27.6, 72.4, 58.4, 62.7, 35.0],
        "atheta_deg": [80.6, 87.9, 85.3, 76.0, 83.0, 60.5, 75.8, 52.6],
        "f": [75.2, 86.5, 90.3, 80.3, 67.6, 48.1, 68.6, 46.2],
    }
    for metric, stated in red.items():
        for c, want in zip(CELLS, stated):
            got = pct(100 * (1 - v("2", "epsm", c, metric) / v("2", "psm", c, metric)))
            check(got == want, f"Table 2 derived reduction {metric} {c}: {got}% vs stated {want}%")
    for c, want in zip(CELLS, [34.5, 32.2, 29.6, 34.8, 25.6, 23.8, 26.9, 6.8]):
        got = pct(v("2", "epsm", c, "time_s") / v("2", "psm", c, "time_s"))
        check(got == want, f"Table 2 time ratio E-PSM/Diosi {c}: {got} vs stated {want}")
    for c, want in zip(CELLS, [155.5, 155.0, 138.3, 127.7, 165.0, 155.9, 141.4, 149.5]):
        got = pct(v("2", "brute_force", c, "time_s") / v("2", "epsm", c, "time_s"))
        check(got == want, f"Table 2 time ratio brute/E-PSM {c}: {got} vs stated {want}")
    # "three orders of magnitude" (prose, L375) is really about 2.1-2.2 orders.
    orders = [math.log10(v("2", "brute_force", c, "time_s") / v("2", "epsm", c, "time_s")) for c in CELLS]
    check(2.1 <= min(orders) and max(orders) < 2.25, f"brute/E-PSM orders of magnitude {min(orders):.2f}-{max(orders):.2f}, expected ~2.1-2.2")

    # Fig 16-19 captions (rect map, 10 % odometry, E-PSM): ax max 13 / mean 2.8 mm, ay max 23 / mean
    # 3.7 mm, atheta max 1.1 / mean 0.1 deg, f max ~54 -> column odo10.
    for metric, stat, lo, hi in [("ax_mm", "max", 13, 13.1), ("ax_mm", "mean", 2.8, 2.85), ("ay_mm", "max", 23, 24),
                                 ("ay_mm", "mean", 3.7, 3.75), ("atheta_deg", "max", 1.1, 1.15),
                                 ("atheta_deg", "mean", 0.05, 0.15), ("f", "max", 54, 54.5)]:
        x = v("2", "epsm", "odo10", metric, stat)
        check(lo <= x < hi, f"Fig 16-19 caption: E-PSM odo10 {metric} {stat} = {x}, expected in [{lo}, {hi})")

    # Prose L375: Diosi atheta means 0.18-0.67 deg, maxima 1.3-10; E-PSM/brute means 0.03-0.28, maxima 0.32-3.2.
    def rng(algs, metric, stat, cells=CELLS, t="2", m="ep_rect_column"):
        xs = [v(t, a, c, metric, stat, m) for a in algs for c in cells]
        return min(xs), max(xs)

    lo, hi = rng(["psm"], "atheta_deg", "mean")
    check(round(lo, 2) == 0.18 and round(hi, 2) == 0.67, f"Diosi atheta means {lo}-{hi}, prose 0.18-0.67")
    lo, hi = rng(["psm"], "atheta_deg", "max")
    check(round(lo, 1) == 1.3 and round(hi) == 10, f"Diosi atheta maxima {lo}-{hi}, prose 1.3-10")
    lo, hi = rng(["epsm", "brute_force"], "atheta_deg", "mean")
    check(round(lo, 2) == 0.03 and round(hi, 2) == 0.29, f"E-PSM/brute atheta means {lo}-{hi}, prose 0.03-0.28 (0.2855 rounds to 0.29)")
    lo, hi = rng(["epsm", "brute_force"], "atheta_deg", "max")
    check(lo == 0.32 and round(hi, 1) == 3.2, f"E-PSM/brute atheta maxima {lo}-{hi}, prose 0.32-3.2")

    # Table 2: every mean is at most its max.
    for a in ["psm", "epsm", "brute_force"]:
        for metric in METRICS5:
            for c in CELLS:
                check(v("2", a, c, metric) <= v("2", a, c, metric, "max"), f"Table 2 {a} {metric} {c}: mean > max")
    # §3.7: CRS2 takes 0.051-0.150 s and E-PSM 0.067-0.111 s per match over Tables 2, 3 and 5.
    crs2_t = [v(t, "crs2", c, "time_s", m=m) for t in ["3", "5"] for m in (MAPS5 if t == "5" else ["ep_rect_column"]) for c in (CELLS7 if t == "3" else CELLS)]
    epsm_t = [v(t, "epsm", c, "time_s", m=m) for t in ["2", "3", "5"] for m in (MAPS5 if t == "5" else ["ep_rect_column"]) for c in (CELLS7 if t == "3" else CELLS)]
    check((round(min(crs2_t), 3), round(max(crs2_t), 2)) == (0.051, 0.15), f"§3.7: CRS2 time {min(crs2_t)}-{max(crs2_t)} s, stated 0.051-0.150")
    check((round(min(epsm_t), 3), round(max(epsm_t), 3)) == (0.067, 0.111), f"§3.7: E-PSM time {min(epsm_t)}-{max(epsm_t)} s, stated 0.067-0.111")

    # C2: E-PSM mean atheta 0.0268-0.2855 vs PSM 0.1766-0.6699; max 0.4525-3.1994 vs 1.3279-10.1063.
    check(rng(["epsm"], "atheta_deg", "mean") == (0.0268, 0.2855), "C2: E-PSM mean atheta range 0.0268-0.2855")
    check(rng(["psm"], "atheta_deg", "mean") == (0.1766, 0.6699), "C2: PSM mean atheta range 0.1766-0.6699")
    check(rng(["epsm"], "atheta_deg", "max") == (0.4525, 3.1994), "C2: E-PSM max atheta range 0.4525-3.1994")
    check(rng(["psm"], "atheta_deg", "max") == (1.3279, 10.1063), "C2: PSM max atheta range 1.3279-10.1063")
    # C3: brute has the lower mean atheta in every cell; E-PSM the lower mean ax in none/odo1/odo5 only.
    check(all(v("2", "brute_force", c, "atheta_deg") < v("2", "epsm", c, "atheta_deg") for c in CELLS), "C3: brute mean atheta < E-PSM in every cell")
    lower_ax = [c for c in CELLS if v("2", "epsm", c, "ax_mm") < v("2", "brute_force", c, "ax_mm")]
    check(lower_ax == ["none", "odo1", "odo5"], f"C3: E-PSM lower mean ax in {lower_ax}, stated none/odo1/odo5")
    check(rng(["brute_force"], "atheta_deg", "mean") == (0.0253, 0.219), "C3: brute mean atheta 0.0253-0.219")
    lo, hi = rng(["brute_force"], "ax_mm", "mean")
    lo2, hi2 = rng(["brute_force"], "ay_mm", "mean")
    check(round(min(lo, lo2), 2) == 0.61 and round(max(hi, hi2), 1) == 15.0, "C3: brute mean position errors 0.61-15.0 mm")

    # Table 3: the Diosi/E-PSM/Brute rows are Table 2's means rounded as printed.
    for a in ["psm", "epsm", "brute_force"]:
        for c in CELLS7:
            for metric in ["f", "time_s"]:
                check(rounded_like(s("2", a, c, metric), s("3", a, c, metric)),
                      f"Table 3 {a} {metric} {c} = {s('3', a, c, metric)} is not Table 2's {s('2', a, c, metric)} rounded")
    # Table 3 CRS2 = Table 5 rect CRS2 (f rounded to 2 decimals, time identical).
    for c in CELLS7:
        check(rounded_like(s("5", "crs2", c, "f"), s("3", "crs2", c, "f")), f"Table 3 CRS2 f {c} is not Table 5's rounded")
        check(s("5", "crs2", c, "time_s") == s("3", "crs2", c, "time_s"), f"Table 3 CRS2 time {c} differs from Table 5's")
    # Best f per column: ISRES 1.15 at no noise, MLSL-LDS elsewhere (0.98, 0.99, 1.36, 3.47, 19.39, 3.50).
    best = [min(T3_ALGS, key=lambda a: v("3", a, c, "f")) for c in CELLS7]
    check(best == ["isres"] + ["mlsl_lds"] * 6, f"Table 3 best f per column: {best}")
    check([s("3", b, c, "f") for b, c in zip(best, CELLS7)] == ["1.15", "0.98", "0.99", "1.36", "3.47", "19.39", "3.50"], "Table 3 best f values")
    # CRS2 vs E-PSM relative f change: -34.1, +9.0, -7.2, -60.5, -46.5, -15.5, -41.9 %.
    for c, want in zip(CELLS7, [-34.1, 9.0, -7.2, -60.5, -46.5, -15.5, -41.9]):
        got = pct(100 * (v("3", "crs2", c, "f") / v("3", "epsm", c, "f") - 1))
        check(got == want, f"Table 3 CRS2 vs E-PSM f change {c}: {got}% vs stated {want}%")
    # C4
    check(v("3", "direct_l", "odo1", "f") > v("3", "slsqp", "odo1", "f") > v("3", "epsm", "odo1", "f"), "C4: DIRECT-L 1.64 > SLSQP 1.63 > E-PSM 1.34 at odo1")
    lo, hi = rng(["cobyla", "bobyqa", "slsqp"], "f", "mean", ["odo5", "odo10"], "3")
    check((lo, hi) == (7.21, 18.21), f"C4: COBYLA/BOBYQA/SLSQP f at 5-10 % odometry {lo}-{hi}, stated 7.21-18.21")
    glob = ["direct_l", "crs2", "isres", "mlsl_lds"]
    check(rng(glob, "f", "mean", ["odo5", "odo10"], "3") == (0.99, 2.06), "C4: globals f at 5-10 % odometry 0.99-2.06")
    check(rng(["slsqp", "lbfgs", "tnewton", "var2"], "f", "mean", ["scan5_odo5"], "3") == (12.27, 12.99), "C4: gradient methods f at 5 mm + 5 % 12.27-12.99")
    check(rng(glob, "f", "mean", ["scan5_odo5"], "3") == (3.50, 3.85), "C4: globals f at 5 mm + 5 % 3.50-3.85")
    check(all(v("3", "psm", c, "f") == max(v("3", a, c, "f") for a in T3_ALGS) for c in CELLS7), "C4: PSM has the worst f in every column")
    # C5 / key facts
    check(rng(["crs2"], "time_s", "mean", CELLS7, "3") == (0.0576, 0.1252), "C5: CRS2 time 0.058-0.125 s")
    check(rng(["epsm"], "time_s", "mean", CELLS7, "3") == (0.0665, 0.087), "C5: E-PSM time 0.067-0.087 s")
    check(rng(["crs2"], "f", "mean", CELLS7, "3") == (1.29, 19.73), "key facts: CRS2 f 1.29-19.73")
    check(rng(["epsm"], "f", "mean", CELLS7, "3") == (1.34, 23.36), "key facts: E-PSM f 1.34-23.36")
    for a, lo_, hi_ in [("direct_l", 2, 15), ("isres", 0.2, 1.9), ("mlsl_lds", 6, 61)]:
        lo, hi = rng([a], "time_s", "mean", CELLS7, "3")
        check(round(lo, 1 if lo_ < 1 else 0) == lo_ and round(hi, 1 if hi_ < 2 else 0) == hi_, f"C5: {a} time {lo}-{hi} s, stated {lo_}-{hi_}")
    worse = [c for c in CELLS7 if v("3", "crs2", c, "f") >= v("3", "epsm", c, "f")]
    check(worse == ["odo1"], f"C5: CRS2 f not below E-PSM in {worse}, stated odo1 only")
    # Erratum: the prose's local optimisers "0.004-0.005 s" are really 0.0048-0.0378 s.
    locs = ["cobyla", "bobyqa", "sbplx", "slsqp", "lbfgs", "tnewton", "var2"]
    check(rng(locs, "time_s", "mean", CELLS7, "3") == (0.0048, 0.0378), "erratum: local optimisers 0.0048-0.0378 s")
    check(rng(["isres"], "time_s", "mean", CELLS7, "3") == (0.21, 1.91), "ISRES 0.21-1.91 s")

    # Table 4: 1 - Diosi/Diosi Original: -38.3, +22.7, +10.9, -8.9, +47.9, +47.8, +44.2, +39.5 %.
    for c, want in zip(CELLS, [-38.3, 22.7, 10.9, -8.9, 47.9, 47.8, 44.2, 39.5]):
        got = pct(100 * (1 - v("4", "psm", c, "f") / v("4", "psm_original", c, "f")))
        check(got == want, f"Table 4 f reduction {c}: {got}% vs stated {want}%")
    check(rng(["psm", "psm_original"], "time_s", "mean", CELLS, "4") == (0.0102, 0.0125), "C1: Table 4 time 0.0102-0.0125 s")
    check(rng(["psm", "psm_original"], "evals", "mean", CELLS, "4") == (14.04, 17.43), "Table 4 evals 14.04-17.43")
    # Prose L430: "7.3 instead of 14" (scan5) and "22.1 instead of 40.7" (scan20): the table has 21.2265.
    check(round(v("4", "psm", "scan5", "f"), 1) == 7.3 and round(v("4", "psm_original", "scan5", "f")) == 14, "Table 4 prose 7.3 vs 14")
    check(round(v("4", "psm_original", "scan20", "f"), 1) == 40.7, "Table 4 prose 40.7")
    check(round(v("4", "psm", "scan20", "f"), 1) == 21.2, "erratum: Table 4 scan20 Diosi f is 21.2265 (prose: 22.1)")
    # Erratum: Diosi differs between Table 2 and Table 4 (f 8.42 vs 6.17, time 0.002 vs 0.0106).
    check((s("2", "psm", "none", "f"), s("4", "psm", "none", "f")) == ("8.4208", "6.172"), "erratum: Diosi no-noise f 8.4208 (T2) vs 6.172 (T4)")
    check((s("2", "psm", "none", "time_s"), s("4", "psm", "none", "time_s")) == ("0.002", "0.0106"), "erratum: Diosi no-noise time 0.002 (T2) vs 0.0106 (T4)")

    # Table 5: f reduction of CRS2 vs E-PSM (1 - C/E).
    red5 = {
        "ep_rect_column": [8.3, -37.3, 22.8, 53.4, 25.2, 15.5, 32.3, 17.2],
        "ep_polygon": [-55.5, 21.9, 3.4, 55.0, 6.6, 6.1, 17.6, -1.6],
        "ep_bigmap": [24.1, 72.1, 52.1, 33.9, 24.1, 14.4, 19.9, 7.3],
    }
    for m, stated in red5.items():
        for c, want in zip(CELLS, stated):
            got = pct(100 * (1 - v("5", "crs2", c, "f", m=m) / v("5", "epsm", c, "f", m=m)))
            check(got == want, f"Table 5 f reduction {m} {c}: {got}% vs stated {want}%")
    # Time ratio CRS2/E-PSM: Rect 0.69-1.35, poly 0.62-1.66, big 1.04-1.77.
    for m, lo_, hi_ in [("ep_rect_column", 0.69, 1.35), ("ep_polygon", 0.62, 1.66), ("ep_bigmap", 1.04, 1.77)]:
        r = [v("5", "crs2", c, "time_s", m=m) / v("5", "epsm", c, "time_s", m=m) for c in CELLS]
        check((round(min(r), 2), round(max(r), 2)) == (lo_, hi_), f"Table 5 time ratio {m}: {min(r):.3f}-{max(r):.3f}, stated {lo_}-{hi_}")
    # C6: CRS2 lower f in 21/24 (7/8, 6/8, 8/8); E-PSM faster in 18/24; largest saving 43.5 % (bigmap2 scan20).
    per_map = [sum(v("5", "crs2", c, "f", m=m) < v("5", "epsm", c, "f", m=m) for c in CELLS) for m in MAPS5]
    check(per_map == [7, 6, 8], f"C6: CRS2 lower f per map {per_map}, stated 7/6/8")
    faster = sum(v("5", "epsm", c, "time_s", m=m) < v("5", "crs2", c, "time_s", m=m) for m in MAPS5 for c in CELLS)
    check(faster == 18, f"C6: E-PSM faster in {faster}/24, stated 18")
    saving = {(m, c): 1 - v("5", "epsm", c, "time_s", m=m) / v("5", "crs2", c, "time_s", m=m) for m in MAPS5 for c in CELLS}
    best = max(saving, key=saving.get)
    check(best == ("ep_bigmap", "scan20") and pct(100 * saving[best]) == 43.5, f"C6: largest E-PSM time saving {best} {100 * saving[best]:.2f}%, stated bigmap2 scan20 43.5%")
    check(pct(100 * (v("5", "epsm", "none", "time_s", m="ep_polygon") / v("5", "crs2", "none", "time_s", m="ep_polygon") - 1)) == 60.2, "C6: poly no-noise E-PSM 60 % longer")
    # Table 5 prose vs table (swapped levels): the big gaps are bigmap odo1 and polygon odo10.
    check(v("5", "epsm", "odo1", "ax_mm", m="ep_bigmap") / v("5", "crs2", "odo1", "ax_mm", m="ep_bigmap") > 30, "bigmap2 odo1 ax gap 5.149 vs 0.1583")
    check(v("5", "epsm", "odo10", "f", m="ep_polygon") / v("5", "crs2", "odo10", "f", m="ep_polygon") > 2, "map2-crow odo10 f gap 6.2484 vs 2.8123")
    # Table 5 anomaly: at no noise bigmap2 E-PSM and CRS2 print identical tiny ax/ay.
    for metric, val in [("ax_mm", "3.40E-06"), ("ay_mm", "5.88E-05")]:
        check(s("5", "epsm", "none", metric, m="ep_bigmap") == s("5", "crs2", "none", metric, m="ep_bigmap") == val, f"bigmap2 no-noise {metric} = {val} for both")
    # C8: the f-check/BOBYQA variant (Table 5) lowers the rect-map f vs plain E-PSM (Table 2).
    check(v("5", "epsm", "odo10", "f") == 3.1891 and v("2", "epsm", "odo10", "f") == 3.7652, "C8: 3.1891 vs 3.7652")
    check(v("5", "epsm", "none", "f") == 1.4906 and v("2", "epsm", "none", "f") == 2.0844, "C8: 1.4906 vs 2.0844")


# --- second pass: rebuild each markdown row and find it in the write-up -------------------------
LABEL = {
    "2": {"psm": "Diosi", "epsm": "E-PSM", "brute_force": "F. bruta (brute force)"},
    "3": {"psm": "Diosi", "epsm": "E-PSM", "brute_force": "Brute Force", "direct_l": "DIRECT-L", "crs2": "CRS2",
          "isres": "ISRES", "mlsl_lds": "GD_MLSL_LDS", "cobyla": "COBYLA", "bobyqa": "BOBYQA", "sbplx": "SBPLX",
          "slsqp": "SLSQP", "lbfgs": "BFGS", "tnewton": "NEWTON", "var2": "VAR2"},
    "4": {"psm": "Diosi", "psm_original": "Diosi Original"},
    "5": {"epsm": "E-PSM", "crs2": "CRS2"},
}
T2_HEAD = {"ax_mm": "**Table 2 — Δx (ax) [mm]**", "ay_mm": "**Table 2 — Δy (ay) [mm]**",
           "atheta_deg": "**Table 2 — Δθ (atheta) [deg]**", "f": "**Table 2 — f [objective, Eq. 4]**",
           "time_s": "**Table 2 — Time [s]**"}
T3_HEAD = {"f": "**f (objective, mean)**", "time_s": "**Time [s] (mean per match)**"}
T4_HEAD = "### 6.4 Table 4"
T4_METRIC = {"f": "Error", "time_s": "Time [s]", "evals": "No. evals"}
T5_HEAD = {"ep_rect_column": "**Rect02-oclu", "ep_polygon": "**map2-crow", "ep_bigmap": "**bigmap2"}
T5_METRIC = {"ax_mm": "ax", "ay_mm": "ay", "atheta_deg": "atheta", "f": "Error (f)", "time_s": "Time"}


def table_lines(doc, heading_prefix, after=0):
    """The markdown table rows under the first line at or after `after` that starts with heading_prefix."""
    i = next(k for k in range(after, len(doc)) if doc[k].startswith(heading_prefix))
    while not doc[i].startswith("|"):
        i += 1
    j = i
    while j < len(doc) and doc[j].startswith("|"):
        j += 1
    return set(doc[i:j]), i


def second_pass(rows, writeup):
    doc = writeup.read_text().splitlines()
    t3_start = next(k for k, l in enumerate(doc) if l.startswith("### 6.3 Table 3"))
    t5_start = next(k for k, l in enumerate(doc) if l.startswith("### 6.5 Table 5"))
    groups = defaultdict(list)
    for r in rows:
        groups[(r["table"], r["map"], r["algorithm"], r["stat"], r["metric"])].append(r)
    found = 0
    for (t, m, a, st, metric), rs in groups.items():
        order = CELLS7 if t == "3" else CELLS
        byc = {r["cell"]: r["value"] for r in rs}
        vals = " | ".join(byc[c] for c in order)
        if t == "2":
            lines, _ = table_lines(doc, T2_HEAD[metric])
            line = f"| {LABEL[t][a]} | {st} | {vals} |"
        elif t == "3":
            lines, _ = table_lines(doc, T3_HEAD[metric], t3_start)
            line = f"| {LABEL[t][a]} | {vals} |"
        elif t == "4":
            lines, _ = table_lines(doc, T4_HEAD)
            line = f"| {T4_METRIC[metric]} | {LABEL[t][a]} | {vals} |"
        else:
            lines, _ = table_lines(doc, T5_HEAD[m], t5_start)
            line = f"| {T5_METRIC[metric]} | {LABEL[t][a]} | {vals} |"
        check(line in lines, f"second pass: table {t} {m} {a} {st} {metric}: row {line!r} not in the write-up")
        found += line in lines
    # and nothing in the write-up's tables is left out: count the data rows of each table
    n_doc = sum(len(table_lines(doc, h)[0]) - 2 for h in T2_HEAD.values())
    n_doc += sum(len(table_lines(doc, h, t3_start)[0]) - 2 for h in T3_HEAD.values())
    n_doc += len(table_lines(doc, T4_HEAD)[0]) - 2
    n_doc += sum(len(table_lines(doc, h, t5_start)[0]) - 2 for h in T5_HEAD.values())
    check(n_doc == len(groups), f"second pass: the write-up's Tables 2-5 have {n_doc} data rows, the CSV {len(groups)} groups")
    return found, len(groups)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--csv", type=Path, default=CSV_PATH, help="the CSV to check (default: epsm-tables.csv beside this script)")
    ap.add_argument("--writeup", type=Path, default=HERE.parents[2] / "shared" / "reference" / "epsm-scan-matching.md")
    args = ap.parse_args()
    rows = load(args.csv)
    counts = structure(rows)
    print("rows per table: " + ", ".join(f"Table {t} {counts[t]}" for t in sorted(counts)) + f"; total {len(rows)}")
    derived(rows)
    if args.writeup.is_file():
        found, n = second_pass(rows, args.writeup)
        print(f"second pass: {found}/{n} rows found verbatim in {args.writeup}")
    else:
        print(f"second pass skipped: {args.writeup} not found")
    print(f"{checks} checks, {len(failures)} failed")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
