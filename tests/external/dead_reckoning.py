"""Dead reckoning as an external algorithm (docs/src/guide/external-algorithms.md): slamlab's test that a
program in another language goes through the same pipeline as the built-in `odometry`.

Composes the odometry increments from the start pose, x_{k+1} = x_k (+) u_k, and writes the TUM
trajectory. Usage: dead_reckoning.py INPUT_DIR OUTPUT_DIR
"""
import math
import sys
import tomllib

def main(inp, out):
    with open(f"{inp}/run.toml", "rb") as f:
        run = tomllib.load(f)
    x, y, th = run["start"]
    poses = [(x, y, th)]
    with open(f"{inp}/odometry.txt") as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            _, dx, dy, dth = line.split()
            dx, dy, dth = float(dx), float(dy), float(dth)
            x, y = x + dx * math.cos(th) - dy * math.sin(th), y + dx * math.sin(th) + dy * math.cos(th)
            th = math.atan2(math.sin(th + dth), math.cos(th + dth))
            poses.append((x, y, th))
    assert len(poses) == run["steps"] + 1, "one pose per step"
    with open(f"{out}/estimate.tum", "w") as f:
        for k, (x, y, th) in enumerate(poses):
            qz, qw = math.sin(th / 2), math.cos(th / 2)
            f.write(f"{k * run['dt_s']:.6f} {x:.9f} {y:.9f} 0 0 0 {qz:.12f} {qw:.12f}\n")

if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
