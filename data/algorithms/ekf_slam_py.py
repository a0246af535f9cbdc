"""EKF-SLAM for range-bearing point landmarks, in Python with numpy, written for slamlab's tests.

An external algorithm: it reads one run's inputs through the file protocol of
docs/external-algorithms.md and writes its trajectory and map back:

    python3 data/algorithms/ekf_slam_py.py INPUT_DIR OUTPUT_DIR

reads INPUT_DIR/run.toml ([base.motion_model], [base.ekf], [landmark_noise]), odometry.txt and
landmarks.txt, and writes OUTPUT_DIR/estimate.tum (steps + 1 poses) and OUTPUT_DIR/map.txt.

It is the algorithm of slamlab's built-in EKF-SLAM (src/slam/ekf/mod.rs) on point-landmark
worlds, written again independently: one joint Gaussian over x = (x, y, θ, m₁, m₂, …). Each step
predicts with the odometry increment, associates every reading of the step against the
predicted map, updates sequentially with the matched ones (Joseph form, O(n²) per reading),
then adds the new landmarks. Under known association, several readings of one identity in a
step are first fused into one (src/slam/observations.rs). Deterministic: it draws no random
number.

References:
- [PR] Thrun, Burgard, Fox, Probabilistic Robotics, Table 10.1 (EKF-SLAM, known
  correspondences) and Table 10.2 (unknown correspondences: Mahalanobis / maximum-likelihood
  association, a new landmark when nothing is close enough).
- [TB] T. Bailey's EKF-SLAM simulator (ekfslam_v1): the χ² gates gate_reject (close enough to
  update) and gate_create (far enough from every landmark to create one), sequential updates,
  augmentation after the updates.
- [EV] "SLAM con EKF y visión artificial" §3.8: covariance_update = "none_on_reobservation"
  (the mean is updated, P is not).
- [FT] the FastSLAM thesis slamlab reproduces: the range-bearing model and its inverse
  (Eqs. 7.21–7.23, with the errata slamlab applies) and the additive pose noise (Eq. 7.18).

Exit status: 0 on success, 2 for a setting this program does not implement (stderr names the
key), 1 for malformed input files.
"""

import math
import sys
import tomllib
from pathlib import Path

import numpy as np

TAU = 2.0 * math.pi
SERIES_BELOW_RAD = 1e-4  # below this turn the arc's functions use their Taylor series


class Unsupported(Exception):
    """A setting this program does not implement: exit status 2."""


def wrap(a):
    """Angle(s) to (−π, π], as slamlab's geom::wrap_angle (a float or a numpy array)."""
    if isinstance(a, float) and -math.pi < a <= math.pi:
        return a  # nearly every angle: untouched
    w = a - TAU * np.round(a / TAU)
    w = np.where(w <= -math.pi, w + TAU, np.where(w > math.pi, w - TAU, w))
    return float(w) if np.ndim(w) == 0 else w


# ---------------------------------------------------------------- motion model ([base.motion_model])

def arc_of(u):
    """The arc (length d, turn φ) that drives increment u (chord length for an off-arc one)."""
    phi = u[2]
    s, c = math.sin(0.5 * phi), math.cos(0.5 * phi)
    chord = u[0] * c + u[1] * s
    return (chord if abs(phi) < SERIES_BELOW_RAD else chord * (0.5 * phi) / s), phi


def arc_jacobian(d, phi):
    """J = ∂u/∂(d, φ) of u = (d sin φ/φ, d (1 − cos φ)/φ, φ)."""
    if abs(phi) < SERIES_BELOW_RAD:
        a, b = 1.0 - phi * phi / 6.0, 0.5 * phi - phi ** 3 / 24.0
        da, db = -phi / 3.0, 0.5 - phi * phi / 8.0
    else:
        s, c = math.sin(phi), math.cos(phi)
        a, b = s / phi, (1.0 - c) / phi
        da, db = (phi * c - s) / phi ** 2, (phi * s - (1.0 - c)) / phi ** 2
    return np.array([[a, d * da], [b, d * db], [0.0, 1.0]])


def process_noise(mm, theta, u):
    """Q, the world-frame covariance of x ⊕ u's error (slamlab's MotionModel::covariance)."""
    if mm["model"] == "pose":  # [FT] Eq. 7.18: additive world-frame noise
        return np.diag([mm["sigma_x_m"] ** 2, mm["sigma_y_m"] ** 2, mm["sigma_theta_rad"] ** 2])
    # proportional: Q = G_u (J diag(σd², σφ²) Jᵀ + floor) G_uᵀ
    d, phi = arc_of(u)
    j = arc_jacobian(d, phi)
    sd, sp = mm["k_translation"] * abs(d), mm["k_rotation"] * abs(phi)
    ft, fr = mm["floor_translation_m"], mm["floor_rotation_rad"]
    n = j @ np.diag([sd * sd, sp * sp]) @ j.T + np.diag([ft * ft, ft * ft, fr * fr])
    s, c = math.sin(theta), math.cos(theta)
    g = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # G_u = ∂(x ⊕ u)/∂u
    return g @ n @ g.T


# ---------------------------------------------------------------- observations

def fuse(a, b):
    """Two readings (z, R) of one landmark from one pose as one (observations.rs `fuse`):
    R̄ = (R_a⁻¹ + R_b⁻¹)⁻¹, z̄ = a + R̄ R_b⁻¹ (b − a), bearing wrapped. None if an R is singular."""
    (za, ra), (zb, rb) = a, b
    if np.linalg.det(ra) == 0.0 or np.linalg.det(rb) == 0.0:
        return None
    ia, ib = np.linalg.inv(ra), np.linalg.inv(rb)
    if np.linalg.det(ia + ib) == 0.0:
        return None
    r = np.linalg.inv(ia + ib)
    r = 0.5 * (r + r.T)
    z = za + r @ ib @ np.array([zb[0] - za[0], wrap(zb[1] - za[1])])
    z[1] = wrap(z[1])
    return (z, r) if np.all(np.isfinite(z)) and np.all(np.isfinite(r)) else None


def fuse_identities(obs):
    """Every group of readings of one identity replaced by their fusion at its first position."""
    obs, i = list(obs), 0
    while i < len(obs):
        if obs[i][2] is not None:
            j = i + 1
            while j < len(obs):
                if obs[j][2] == obs[i][2]:
                    f = fuse(obs[i][:2], obs[j][:2])
                    if f is not None:
                        obs[i] = (f[0], f[1], obs[i][2])
                        del obs[j]
                        continue
                j += 1
        i += 1
    return obs


# ---------------------------------------------------------------- the filter

class Ekf:
    def __init__(self, ekf, mm, start):
        self.p_ekf, self.mm = ekf, mm
        sm, sr = ekf["initial_pose_sigma_m"], ekf["initial_pose_sigma_rad"]
        self.x = np.array(start, dtype=float)
        self.P = np.diag([sm * sm, sm * sm, sr * sr])
        self.ids = []  # per landmark: its true identity (known association) or None
        self.failures = 0

    def predict(self, u):
        """x_r ← x_r ⊕ u; P_rr ← F P_rr Fᵀ + Q; P_rm ← F P_rm (touches only the pose rows/columns)."""
        x, y, th = self.x[:3]
        s, c = math.sin(th), math.cos(th)
        f = np.array([[1.0, 0.0, -s * u[0] - c * u[1]], [0.0, 1.0, c * u[0] - s * u[1]], [0.0, 0.0, 1.0]])
        q = process_noise(self.mm, th, u)
        self.x[:3] = (x + c * u[0] - s * u[1], y + s * u[0] + c * u[1], wrap(th + u[2]))
        prr = f @ self.P[:3, :3] @ f.T + q
        self.P[:3, :3] = 0.5 * (prr + prr.T)
        if len(self.x) > 3:
            prm = f @ self.P[:3, 3:]
            self.P[:3, 3:] = prm
            self.P[3:, :3] = prm.T

    def predicted(self, js):
        """For landmarks js: ẑ = h(x, m_j), H's pose and landmark blocks, and H P Hᵀ from the 5 × 5
        block of P that H = [H_pose 0 … H_landmark 0 …] touches ([PR] Table 10.1 lines 12–16;
        [FT] Eqs. 7.21–7.22)."""
        idx = 3 + 2 * np.asarray(js)
        dx, dy = self.x[idx] - self.x[0], self.x[idx + 1] - self.x[1]
        q = dx * dx + dy * dy
        rng = np.sqrt(q)
        zhat = np.stack([rng, wrap(np.arctan2(dy, dx) - self.x[2])], 1)
        h = np.zeros((len(idx), 2, 5))  # columns x, y, θ, m_x, m_y
        with np.errstate(divide="ignore", invalid="ignore"):  # a landmark at the robot: S not finite
            h[:, 0, 0], h[:, 0, 1] = -dx / rng, -dy / rng  # ∂r/∂(x, y, θ) = (−Δx/r, −Δy/r, 0)
            h[:, 1, 0], h[:, 1, 1], h[:, 1, 2] = dy / q, -dx / q, -1.0  # ∂φ/∂(x, y, θ) = (Δy/q, −Δx/q, −1)
        h[:, :, 3:] = -h[:, :, :2]  # ∂ẑ/∂m
        cols = np.empty((len(idx), 5), dtype=int)
        cols[:, :3], cols[:, 3], cols[:, 4] = (0, 1, 2), idx, idx + 1
        hph = h @ self.P[cols[:, :, None], cols[:, None, :]] @ h.transpose(0, 2, 1)
        return zhat, h[:, :, :3], h[:, :, 3:], hph

    def gate(self, zs, rs, js):
        """Every reading (zs, rs: rows) against every landmark js (columns): ν = z − ẑ (bearing
        wrapped), S = H P Hᵀ + R, whether S is positive definite (its Cholesky factor exists) and
        the normalised innovation squared νᵀS⁻¹ν."""
        zhat, _, _, hph = self.predicted(js)
        s = hph[None] + rs[:, None]
        s = 0.5 * (s + s.swapaxes(2, 3))
        a, b, d = s[..., 0, 0], s[..., 0, 1], s[..., 1, 1]
        det = a * d - b * b
        ok = (a > 0.0) & (det > 0.0)
        nu = zs[:, None, :] - zhat[None]
        nu[..., 1] = wrap(nu[..., 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            nis = (nu[..., 0] ** 2 * d - 2.0 * nu[..., 0] * nu[..., 1] * b + nu[..., 1] ** 2 * a) / det
        return s, det, ok, nis

    def associate(self, obs):
        """('update', j), ('new',) or ('ignored',) for each reading of a step, all against the
        state after the prediction."""
        e = self.p_ekf
        if e["association"] == "known":  # [PR] Table 10.1: by the sensor's identities
            return [self.associate_known(z, r, ident) for z, r, ident in obs]
        # [PR] Table 10.2 / [TB] data_associate: among landmarks with NIS < gate_reject the one
        # with the smallest score (NIS, or NIS + ln det S = −2 ln N(ν; 0, S) + const for maximum
        # likelihood); none such, and every NIS > gate_create: new; otherwise ignored
        if not obs:
            return []
        if not self.ids:
            return [("new",) if math.inf > e["gate_create"] else ("ignored",)] * len(obs)
        zs, rs = np.array([o[0] for o in obs]), np.array([o[1] for o in obs])
        s, det, ok, nis = self.gate(zs, rs, np.arange(len(self.ids)))
        self.failures += int(np.count_nonzero(~ok))  # S not positive definite: skipped
        valid = ok & ~np.isnan(nis)
        score = nis
        if e["association"] == "maximum_likelihood":
            with np.errstate(divide="ignore", invalid="ignore"):
                score = nis + np.log(det)
        gated = valid & (nis < e["gate_reject"])
        decisions = []
        for o in range(len(obs)):
            nearest = float(np.min(nis[o][valid[o]])) if valid[o].any() else math.inf
            if gated[o].any():  # the first of equal scores, as the built-in
                decisions.append(("update", int(np.argmin(np.where(gated[o], score[o], np.inf)))))
            else:
                decisions.append(("new",) if nearest > e["gate_create"] else ("ignored",))
        return decisions

    def associate_known(self, z, r, ident):
        gate = self.p_ekf["known_outlier_gate"]
        if ident is None:
            self.failures += 1  # known association needs identities: counted, ignored
            return ("ignored",)
        if ident not in self.ids:
            return ("new",)
        j = self.ids.index(ident)
        if math.isfinite(gate):  # the outlier gate (off by default): NIS above it → ignored
            _, _, ok, nis = self.gate(z[None], r[None], [j])
            if not ok[0, 0]:
                self.failures += 1
                return ("ignored",)
            if not nis[0, 0] <= gate:
                return ("ignored",)
        return ("update", j)

    def update(self, z, r, j):
        """Sequential EKF update with one reading of landmark j ([PR] Table 10.1 lines 17–19),
        Joseph form in O(n²): with W = P Hᵀ, A = (I − KH) P = P − K Wᵀ, and
        A (I − KH)ᵀ + K R Kᵀ = A − (A Hᵀ − K R) Kᵀ. On a singular S or a non-finite gain the
        state is left as it was (counted)."""
        zhat, hp, hl, hph = self.predicted([j])
        hp, hl, s = hp[0], hl[0], hph[0] + r
        s = 0.5 * (s + s.T)
        if not (s[0, 0] > 0.0 and s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0] > 0.0):
            self.failures += 1
            return
        nu = np.array([z[0] - zhat[0, 0], wrap(float(z[1] - zhat[0, 1]))])
        i = 3 + 2 * j
        w = self.P[:, :3] @ hp.T + self.P[:, i:i + 2] @ hl.T  # P Hᵀ
        k = w @ np.linalg.inv(s)  # K = P Hᵀ S⁻¹
        dx = k @ nu
        if not (np.all(np.isfinite(k)) and np.all(np.isfinite(dx))):
            self.failures += 1
            return
        self.x += dx
        self.x[2] = wrap(float(self.x[2]))
        if self.p_ekf["covariance_update"] == "joseph":  # else [EV]: P left as it is
            self.P -= k @ w.T
            b = self.P[:, :3] @ hp.T + self.P[:, i:i + 2] @ hl.T - k @ r
            self.P -= b @ k.T
            self.P = 0.5 * (self.P + self.P.T)

    def augment(self, z, r, ident):
        """Adds m = g⁻¹(x_r, z) ([FT] Eq. 7.23) with P_mm = G_p P_rr G_pᵀ + G_z R G_zᵀ and
        P_m· = G_p P_r· ([TB] augment)."""
        px, py, th = self.x[:3]
        a = z[1] + th
        s, c = math.sin(a), math.cos(a)
        m = np.array([px + z[0] * c, py + z[0] * s])
        gp = np.array([[1.0, 0.0, -z[0] * s], [0.0, 1.0, z[0] * c]])
        gz = np.array([[c, -z[0] * s], [s, z[0] * c]])
        cross = gp @ self.P[:3, :]
        pmm = gp @ self.P[:3, :3] @ gp.T + gz @ r @ gz.T
        if not (np.all(np.isfinite(m)) and np.all(np.isfinite(cross)) and np.all(np.isfinite(pmm))):
            self.failures += 1
            return
        n = len(self.x)
        self.x = np.concatenate([self.x, m])
        p = np.zeros((n + 2, n + 2))
        p[:n, :n] = self.P
        p[n:, :n], p[:n, n:] = cross, cross.T
        p[n:, n:] = 0.5 * (pmm + pmm.T)
        self.P = p
        self.ids.append(ident if self.p_ekf["association"] == "known" else None)

    def step(self, u, obs):
        """predict → associate all (against the predicted map) → update matched → augment new."""
        if u is not None:
            self.predict(u)
        decisions = self.associate(obs)
        for (z, r, _), d in zip(obs, decisions):
            if d[0] == "update":
                self.update(z, r, d[1])
        for (z, r, ident), d in zip(obs, decisions):
            if d[0] == "new":
                self.augment(z, r, ident)


# ---------------------------------------------------------------- the protocol

EKF_DEFAULTS = {"association": "nearest_neighbour", "gate_reject": 4.0, "gate_create": 25.0,
                "initial_pose_sigma_m": 0.0, "initial_pose_sigma_rad": 0.0,
                "covariance_update": "joseph", "known_outlier_gate": math.inf,
                "laser_var_rho_m2": 0.04, "laser_var_theta_rad2": 0.00122}  # laser_*: unused on point worlds
MOTION_KEYS = {"pose": ("sigma_x_m", "sigma_y_m", "sigma_theta_rad"),
               "proportional": ("k_translation", "k_rotation", "floor_translation_m", "floor_rotation_rad")}
MOTION_DEFAULT = {"model": "proportional", "k_translation": 0.1, "k_rotation": 0.1,
                  "floor_translation_m": 1e-7, "floor_rotation_rad": 1e-7}
MOTION_NOTES = ("floor_reason",)  # documentation only: read and ignored
CHOICES = {"association": ("known", "nearest_neighbour", "maximum_likelihood"),
           "covariance_update": ("joseph", "none_on_reobservation")}
RANGE_NOISE = {"constant": lambda s, r: s, "proportional": lambda s, r: s * r,
               "quadratic": lambda s, r: s * r * r}


def settings(run):
    """[base.ekf], [base.motion_model] and [landmark_noise], checked: Unsupported names the key."""
    if run.get("protocol") != 1:
        raise Unsupported(f"protocol = {run.get('protocol')!r}: only protocol 1 is implemented")
    if run.get("world") != "points":
        raise Unsupported(f"world = {run.get('world')!r}: only \"points\" (point landmarks) is implemented")
    if run.get("params"):
        raise Unsupported(f"[params] {next(iter(run['params']))}: this program has no parameters of its own")
    base = run.get("base", {})
    ekf = dict(EKF_DEFAULTS)
    for key, value in base.get("ekf", {}).items():
        if key not in EKF_DEFAULTS:
            raise Unsupported(f"[base.ekf] {key}: unknown key, not implemented")
        ekf[key] = value
    for key, allowed in CHOICES.items():
        if ekf[key] not in allowed:
            raise Unsupported(f"[base.ekf] {key} = {ekf[key]!r} is not implemented (only {', '.join(allowed)})")
    mm = dict(base.get("motion_model", MOTION_DEFAULT))
    if mm.get("model") not in MOTION_KEYS:
        raise Unsupported(f"[base.motion_model] model = {mm.get('model')!r} is not implemented (only pose, proportional)")
    for key in mm:
        if key != "model" and key not in MOTION_KEYS[mm["model"]] + MOTION_NOTES:
            raise Unsupported(f"[base.motion_model] {key}: unknown key for model = {mm['model']!r}")
    for key in MOTION_KEYS[mm["model"]]:
        if key not in mm:
            raise Unsupported(f"[base.motion_model] {key}: missing for model = {mm['model']!r}")
    noise = run.get("landmark_noise")
    if noise is None:
        raise Unsupported("[landmark_noise]: missing (the descriptor must read landmarks)")
    if noise.get("range_noise") not in RANGE_NOISE:
        raise Unsupported(f"[landmark_noise] range_noise = {noise.get('range_noise')!r} is not implemented "
                          f"(only {', '.join(RANGE_NOISE)})")
    return ekf, mm, noise


def read_rows(path, width):
    rows = []
    for n, line in enumerate(path.read_text().splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        fields = line.split()
        if len(fields) != width:
            raise ValueError(f"{path}:{n}: expected {width} fields, got {len(fields)}")
        rows.append([float(v) for v in fields])
    return rows


def main(argv):
    if len(argv) != 3:
        print("usage: ekf_slam_py.py INPUT_DIR OUTPUT_DIR", file=sys.stderr)
        return 2
    inp, out = Path(argv[1]), Path(argv[2])
    with open(inp / "run.toml", "rb") as f:
        run = tomllib.load(f)
    try:
        ekf, mm, noise = settings(run)
    except Unsupported as e:
        print(f"ekf_slam_py: {e}", file=sys.stderr)
        return 2
    steps, dt = int(run["steps"]), float(run["dt_s"])
    odometry = read_rows(inp / "odometry.txt", 4)
    if [int(r[0]) for r in odometry] != list(range(steps)):
        raise ValueError(f"{inp / 'odometry.txt'}: expected lines k = 0 … {steps - 1}")
    sr, sb = noise["range_sigma_m"], noise["bearing_sigma_rad"]
    sigma = RANGE_NOISE[noise["range_noise"]]
    readings = [[] for _ in range(steps + 1)]  # per step: (z, R(measured range), identity or None)
    lm_path = inp / "landmarks.txt"
    for step, rng, bearing, ident in (read_rows(lm_path, 4) if lm_path.exists() else []):
        if 0 <= int(step) <= steps:
            s = sigma(sr, rng)
            readings[int(step)].append((np.array([rng, bearing]), np.diag([s * s, sb * sb]),
                                        None if ident < 0 else int(ident)))
    filt = Ekf(ekf, mm, [float(v) for v in run["start"]])
    lines = []
    for k in range(steps + 1):
        obs = readings[k]
        if ekf["association"] == "known":
            obs = fuse_identities(obs)
        filt.step(None if k == 0 else odometry[k - 1][1:], obs)
        x, y, th = (float(v) for v in filt.x[:3])
        lines.append(f"{k * dt:.6f} {x:.9f} {y:.9f} 0 0 0 {math.sin(0.5 * th):.12f} {math.cos(0.5 * th):.12f}")
    out.mkdir(parents=True, exist_ok=True)
    (out / "estimate.tum").write_text("\n".join(lines) + "\n")
    with open(out / "map.txt", "w") as f:
        for j, ident in enumerate(filt.ids):
            mx, my = filt.x[3 + 2 * j], filt.x[4 + 2 * j]
            f.write(f"{mx:.9f} {my:.9f}" + ("" if ident is None else f" {ident}") + "\n")
    print(f"ekf_slam_py: {len(filt.ids)} landmarks, {filt.failures} numerical failures", file=sys.stderr)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv))
    except (OSError, ValueError, KeyError, tomllib.TOMLDecodeError) as e:
        print(f"ekf_slam_py: malformed input: {e!r}", file=sys.stderr)
        sys.exit(1)
