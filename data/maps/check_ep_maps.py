#!/usr/bin/env python3
"""Checks the three [EP] segment maps (ep_rect_column, ep_polygon, ep_bigmap) and draws them.

For each map it checks that
  - the start pose and every waypoint keep >= 0.6 m from every wall,
  - every straight leg of the scripted path (start -> waypoints, laps times) keeps >= 0.4 m from
    every wall (the simulator does not check collisions),
  - the path the simulator really drives keeps >= 0.4 m too: the turn-then-drive controller of
    src/world/trajectory.rs is re-run here at dt = 0.1 s (default [base.sim] dt_s),
  - the start lies inside the outer wall (the first, closed polyline) and the lap is closed,
and prints the map's size, wall count, path length, number of spins on the spot and an estimate of
the number of scan matches (one per 0.5 m travelled or 30 deg turned, whichever comes first).

It writes one SVG per map (walls black, planned legs blue, simulated path red, waypoints as dots)
to --out (default: a fresh temporary folder), never into the repository. Standard library only (Python >= 3.11).

    python3 data/maps/check_ep_maps.py [--out DIR]

Exit status 1 if any check fails.
"""

import argparse
import math
import sys
import tempfile
import tomllib
from pathlib import Path

MAPS = ["ep_rect_column", "ep_polygon", "ep_bigmap"]
WAYPOINT_CLEARANCE_M = 0.6
LEG_CLEARANCE_M = 0.4
DT_S = 0.1
# src/world/trajectory.rs
HEADING_GAIN_PER_S = 1.5
TURN_IN_PLACE_RAD = 0.5
# scan-match trigger used for the estimate only (the brief's "one every ~0.5 m or ~30 deg")
MATCH_DIST_M = 0.5
MATCH_TURN_RAD = math.radians(30.0)


def wrap(a):
    """Angle to (-pi, pi], as geom::wrap_angle."""
    if -math.pi < a <= math.pi:
        return a
    w = a - 2 * math.pi * round(a / (2 * math.pi))
    if w <= -math.pi:
        return w + 2 * math.pi
    if w > math.pi:
        return w - 2 * math.pi
    return w


def point_segment_distance(p, a, b):
    ax, ay = a
    bx, by = b
    dx, dy = bx - ax, by - ay
    l2 = dx * dx + dy * dy
    t = 0.0 if l2 == 0 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / l2))
    return math.hypot(p[0] - (ax + t * dx), p[1] - (ay + t * dy))


def _cross(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def segments_intersect(p1, p2, q1, q2):
    d1, d2 = _cross(q1, q2, p1), _cross(q1, q2, p2)
    d3, d4 = _cross(p1, p2, q1), _cross(p1, p2, q2)
    return ((d1 > 0) != (d2 > 0)) and ((d3 > 0) != (d4 > 0)) and d1 * d2 < 0 and d3 * d4 < 0


def segment_segment_distance(p1, p2, q1, q2):
    if segments_intersect(p1, p2, q1, q2):
        return 0.0
    return min(
        point_segment_distance(p1, q1, q2),
        point_segment_distance(p2, q1, q2),
        point_segment_distance(q1, p1, p2),
        point_segment_distance(q2, p1, p2),
    )


def point_in_polygon(p, poly):
    inside = False
    for (x1, y1), (x2, y2) in zip(poly, poly[1:]):
        if (y1 > p[1]) != (y2 > p[1]):
            x = x1 + (p[1] - y1) * (x2 - x1) / (y2 - y1)
            if x > p[0]:
                inside = not inside
    return inside


def drive(start, waypoints, laps, v_max, omega_max, tol):
    """Re-implements src/world/trajectory.rs::drive: returns poses and controls."""
    x, y, th = start
    poses = [(x, y, th)]
    controls = []
    for leg in range(len(waypoints) * laps):
        tx, ty = waypoints[leg % len(waypoints)]
        steps = 0
        while math.hypot(tx - x, ty - y) > tol:
            steps += 1
            if steps > 1_000_000:
                raise RuntimeError(f"controller stuck on leg {leg}")
            dist = math.hypot(tx - x, ty - y)
            err = wrap(math.atan2(ty - y, tx - x) - th)
            omega = max(-omega_max, min(omega_max, HEADING_GAIN_PER_S * err))
            v = 0.0 if abs(err) >= TURN_IN_PLACE_RAD else min(v_max * (1 - abs(err) / TURN_IN_PLACE_RAD), dist / DT_S)
            dth = omega * DT_S
            if abs(omega) < 1e-6:
                d = v * DT_S
                ddx, ddy = d * math.cos(0.5 * dth), d * math.sin(0.5 * dth)
            else:
                r = v / omega
                ddx, ddy = r * math.sin(dth), r * 2 * math.sin(0.5 * dth) ** 2
            s, c = math.sin(th), math.cos(th)
            x, y, th = x + c * ddx - s * ddy, y + s * ddx + c * ddy, wrap(th + dth)
            poses.append((x, y, th))
            controls.append((v, omega))
    return poses, controls


def spins(controls):
    """Maximal runs of steps with v = 0 and omega != 0: (steps, angle turned [deg])."""
    out, run, angle = [], 0, 0.0
    for v, w in controls + [(1.0, 0.0)]:
        if v == 0.0 and w != 0.0:
            run += 1
            angle += w * DT_S
        elif run:
            out.append((run, math.degrees(abs(angle))))
            run, angle = 0, 0.0
    return out


def estimate_matches(poses):
    n, dist, turn = 0, 0.0, 0.0
    for (x0, y0, t0), (x1, y1, t1) in zip(poses, poses[1:]):
        dist += math.hypot(x1 - x0, y1 - y0)
        turn += abs(wrap(t1 - t0))
        if dist >= MATCH_DIST_M or turn >= MATCH_TURN_RAD:
            n, dist, turn = n + 1, 0.0, 0.0
    return n


def svg(name, walls, legs, poses, waypoints, start, path):
    xs = [p[0] for w in walls for p in w]
    ys = [p[1] for w in walls for p in w]
    x0, x1, y0, y1 = min(xs) - 1, max(xs) + 1, min(ys) - 1, max(ys) + 1
    scale = 900 / max(x1 - x0, y1 - y0)
    W, H = (x1 - x0) * scale, (y1 - y0) * scale

    def P(p):
        return f"{(p[0] - x0) * scale:.1f},{(y1 - p[1]) * scale:.1f}"

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W:.0f}" height="{H:.0f}" viewBox="0 0 {W:.0f} {H:.0f}">',
           '<rect width="100%" height="100%" fill="white"/>']
    # 1 m grid
    for gx in range(math.ceil(x0), math.floor(x1) + 1):
        out.append(f'<line x1="{(gx - x0) * scale:.1f}" y1="0" x2="{(gx - x0) * scale:.1f}" y2="{H:.0f}" stroke="#eee"/>')
    for gy in range(math.ceil(y0), math.floor(y1) + 1):
        out.append(f'<line x1="0" y1="{(y1 - gy) * scale:.1f}" x2="{W:.0f}" y2="{(y1 - gy) * scale:.1f}" stroke="#eee"/>')
    for w in walls:
        out.append(f'<polyline points="{" ".join(P(p) for p in w)}" fill="none" stroke="black" stroke-width="3"/>')
    out.append(f'<polyline points="{" ".join(P(p) for p in legs)}" fill="none" stroke="#69f" stroke-width="6" stroke-opacity="0.4"/>')
    out.append(f'<polyline points="{" ".join(P(p) for p in poses[::2])}" fill="none" stroke="red" stroke-width="1.5"/>')
    for i, w in enumerate(waypoints):
        out.append(f'<circle cx="{P(w).split(",")[0]}" cy="{P(w).split(",")[1]}" r="4" fill="blue"/>')
        out.append(f'<text x="{(w[0] - x0) * scale + 6:.1f}" y="{(y1 - w[1]) * scale - 6:.1f}" font-size="14" fill="blue">{i + 1}</text>')
    sx, sy, st = start
    tip = (sx + 0.6 * math.cos(st), sy + 0.6 * math.sin(st))
    out.append(f'<circle cx="{P(start).split(",")[0]}" cy="{P(start).split(",")[1]}" r="7" fill="green"/>')
    out.append(f'<polyline points="{P(start)} {P(tip)}" stroke="green" stroke-width="3"/>')
    out.append(f'<text x="10" y="20" font-size="16">{name} (grid 1 m)</text>')
    out.append("</svg>")
    path.write_text("\n".join(out) + "\n")


def check(path, out_dir):
    problems = []
    with open(path, "rb") as f:
        m = tomllib.load(f)
    name = m["name"]
    if name != path.stem:
        problems.append(f"name {name!r} is not the file stem {path.stem!r}")
    walls = [[tuple(map(float, p)) for p in w["points"]] for w in m["walls"]]
    segs = [(a, b) for w in walls for a, b in zip(w, w[1:])]
    t = m["trajectory"]
    s = m["start"]
    start = (s["x_m"], s["y_m"], math.radians(s["theta_deg"]))
    wps = [tuple(map(float, w)) for w in t["waypoints"]]
    laps = t["laps"]

    outer = walls[0]
    if outer[0] != outer[-1]:
        problems.append("the first wall is not a closed outline")
    for i, p in enumerate([start[:2]] + wps):
        label = "start" if i == 0 else f"waypoint {i}"
        if not point_in_polygon(p, outer):
            problems.append(f"{label} {p} is outside the outer wall")
        for w in walls[1:]:
            if len(w) > 3 and w[0] == w[-1] and point_in_polygon(p, w):
                problems.append(f"{label} {p} is inside an obstacle")
        c = min(point_segment_distance(p, a, b) for a, b in segs)
        if c < WAYPOINT_CLEARANCE_M:
            problems.append(f"{label} {p} is {c:.3f} m from a wall (< {WAYPOINT_CLEARANCE_M})")
    if math.hypot(wps[-1][0] - start[0], wps[-1][1] - start[1]) > 1e-9:
        problems.append("the lap is not closed: the last waypoint is not the start position")

    legs = [start[:2]] + wps * laps
    leg_clear = min(min(segment_segment_distance(p, q, a, b) for a, b in segs) for p, q in zip(legs, legs[1:]))
    wp_clear = min(min(point_segment_distance(p, a, b) for a, b in segs) for p in [start[:2]] + wps)
    if leg_clear < LEG_CLEARANCE_M:
        problems.append(f"a leg comes {leg_clear:.3f} m from a wall (< {LEG_CLEARANCE_M})")

    poses, controls = drive(start, wps, laps, t["max_speed_mps"], math.radians(t.get("max_turn_rate_dps", 45.0)), t.get("waypoint_tolerance_m", 0.2))
    sim_clear = min(min(segment_segment_distance(p[:2], q[:2], a, b) for a, b in segs) for p, q in zip(poses, poses[1:]))
    if sim_clear < LEG_CLEARANCE_M:
        problems.append(f"the simulated path comes {sim_clear:.3f} m from a wall (< {LEG_CLEARANCE_M})")
    length = sum(math.hypot(q[0] - p[0], q[1] - p[1]) for p, q in zip(poses, poses[1:]))
    planned = sum(math.hypot(q[0] - p[0], q[1] - p[1]) for p, q in zip(legs, legs[1:]))
    sp = [s_ for s_ in spins(controls) if s_[1] > 1.0]
    oblique = sum(1 for a, b in segs if abs(a[0] - b[0]) > 1e-9 and abs(a[1] - b[1]) > 1e-9)

    xs = [p[0] for p in outer]
    ys = [p[1] for p in outer]
    print(f"{name}: {max(xs) - min(xs):g} x {max(ys) - min(ys):g} m, {len(segs)} walls ({oblique} oblique), "
          f"outer outline {len(outer) - 1} vertices")
    print(f"  path: {laps} lap(s) x {len(wps)} waypoints, planned {planned:.1f} m, driven {length:.1f} m in {len(controls) * DT_S:.0f} s")
    print(f"  spins on the spot: {len(sp)} ({min(a for _, a in sp):.0f}-{max(a for _, a in sp):.0f} deg turned in place each)")
    print(f"  clearance: waypoints >= {wp_clear:.3f} m, planned legs >= {leg_clear:.3f} m, simulated path >= {sim_clear:.3f} m")
    print(f"  estimated scan matches (0.5 m or 30 deg): {estimate_matches(poses)}")

    out_dir.mkdir(parents=True, exist_ok=True)
    svg(name, walls, legs, poses, wps, start, out_dir / f"{name}.svg")
    for p in problems:
        print(f"  FAIL: {p}")
    return problems


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None, help="folder for the SVGs (default: a fresh temporary folder)")
    args = ap.parse_args()
    if args.out is None:
        args.out = Path(tempfile.mkdtemp(prefix="ep_maps-"))
    here = Path(__file__).resolve().parent
    failed = False
    for name in MAPS:
        failed |= bool(check(here / f"{name}.toml", args.out))
    print(f"SVGs in {args.out}")
    print("FAILED" if failed else "all checks passed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
