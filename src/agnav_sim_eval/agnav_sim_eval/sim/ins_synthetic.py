"""Synthetic truth trajectories, consumer-MEMS IMU and GNSS signals for INS tests and benchmarks.

The IMU is derived from the truth by inverting the strapdown equations (earth rate, transport
rate, Coriolis, normal gravity), so a perfect IMU reproduces the truth; `MemsGrade` then adds a
documented consumer-MEMS error model ([IMPL]: SPEC gives no accelerometer for §7):
white noise (ARW/VRW), turn-on bias (constant per run), first-order Gauss-Markov bias
instability and a fixed scale-factor error per axis.
"""
import math
from dataclasses import dataclass

import numpy as np
from agnav_fusion.ins import earth
from agnav_fusion.ins.measurements import ENU_TO_NED, GnssSample


@dataclass
class Trajectory:
    """Truth of the IMU point at rate 1/dt: geodetic rad/m, NED velocity, FRD->NED attitude."""

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    v_ned: np.ndarray
    c_b_ned: np.ndarray      # (N, 3, 3)

    def euler(self):
        """(roll, pitch nose-up, heading clockwise from north) arrays."""
        c = self.c_b_ned
        return (np.arctan2(c[:, 2, 1], c[:, 2, 2]), -np.arcsin(np.clip(c[:, 2, 0], -1, 1)),
                np.arctan2(c[:, 1, 0], c[:, 0, 0]))


def dcm_from_euler(roll, pitch, heading):
    """FRD -> NED, Z-Y-X (5-5-2)."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(heading), math.sin(heading))
    return np.array([[cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy],
                     [cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy],
                     [-sp, sr * cp, cr * cp]])


def drive(segments, dt=0.01, lat0=math.radians(43.07), lon0=math.radians(141.34), h0=20.0,
          heading0=0.0, tilt=None):
    """Ground-vehicle trajectory from segments (duration s, acceleration m/s^2, yaw rate rad/s, cw+).

    The velocity is along the body x axis (no side-slip); tilt(t) -> (roll, pitch) adds terrain.
    """
    n = int(round(sum(s[0] for s in segments) / dt)) + 1
    t = np.arange(n) * dt
    acc, rate = np.zeros(n), np.zeros(n)
    edges = np.cumsum([0.0] + [s[0] for s in segments])
    for (dur, a, r), t0 in zip(segments, edges):
        sel = (t >= t0 - 1e-9) & (t < t0 + dur - 1e-9)
        acc[sel], rate[sel] = a, r
    speed = np.maximum(np.concatenate([[0.0], np.cumsum(acc[:-1] * dt)]), 0.0)
    heading = heading0 + np.concatenate([[0.0], np.cumsum(rate[:-1] * dt)])
    lat, lon, h = np.empty(n), np.empty(n), np.empty(n)
    v_ned, c = np.empty((n, 3)), np.empty((n, 3, 3))
    lat[0], lon[0], h[0] = lat0, lon0, h0
    for k in range(n):
        roll, pitch = tilt(t[k]) if tilt else (0.0, 0.0)
        c[k] = dcm_from_euler(roll, pitch, heading[k])
        v_ned[k] = c[k] @ np.array([speed[k], 0.0, 0.0])
    # position with the mid-interval velocity, as the mechanization integrates it
    for k in range(n - 1):
        vm = 0.5 * (v_ned[k] + v_ned[k + 1])
        rm, rn = earth.radii(lat[k])
        lat[k + 1] = lat[k] + vm[0] * dt / (rm + h[k])
        lon[k + 1] = lon[k] + vm[1] * dt / ((rn + h[k]) * math.cos(lat[k]))
        h[k + 1] = h[k] - vm[2] * dt
    return Trajectory(t, lat, lon, h, v_ned, c)


def _log_so3(r):
    cos_a = min(max((np.trace(r) - 1.0) / 2.0, -1.0), 1.0)
    a = math.acos(cos_a)
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return 0.5 * w if a < 1e-9 else a / (2.0 * math.sin(a)) * w


def ideal_imu(traj):
    """Perfect gyro [rad/s] and accelerometer [m/s^2] (FRD) for each interval k -> k+1."""
    n = len(traj.t) - 1
    gyro, accel = np.empty((n, 3)), np.empty((n, 3))
    for k in range(n):
        dt = traj.t[k + 1] - traj.t[k]
        lat, h = traj.lat[k], traj.h[k]
        rm, rn = earth.radii(lat)
        v = 0.5 * (traj.v_ned[k] + traj.v_ned[k + 1])
        om = earth.OMEGA * np.array([math.cos(lat), 0.0, -math.sin(lat)])
        rho = np.array([v[1] / (rn + h), -v[0] / (rm + h), -v[1] * math.tan(lat) / (rn + h)])
        c0, c1 = traj.c_b_ned[k], traj.c_b_ned[k + 1]
        gyro[k] = _log_so3(c0.T @ c1) / dt + c1.T @ (om + rho)
        a = (traj.v_ned[k + 1] - traj.v_ned[k]) / dt
        f_n = a - np.array([0.0, 0.0, earth.gravity(lat, h)]) + np.cross(2.0 * om + rho, traj.v_ned[k])
        accel[k] = c1.T @ f_n
    return gyro, accel


@dataclass
class MemsGrade:
    """Consumer MEMS IMU (BMI088 / ICM-42688 class) error model, 1-sigma per axis."""

    gyro_arw: float = math.radians(0.01)           # rad/s/sqrt(Hz)  (0.6 deg/sqrt(h))
    gyro_turn_on_bias: float = math.radians(0.1)   # rad/s  (360 deg/h)
    gyro_instability: float = math.radians(10.0 / 3600)  # rad/s GM sigma
    gyro_scale: float = 0.002
    accel_vrw: float = 150e-6 * 9.81               # m/s^2/sqrt(Hz)
    accel_turn_on_bias: float = 0.01 * 9.81        # 10 mg
    accel_instability: float = 0.1e-3 * 9.81       # m/s^2 GM sigma
    accel_scale: float = 0.002
    tau: float = 300.0                             # GM correlation time [s]

    def corrupt(self, gyro, accel, dt, rng):
        """Noisy (gyro, accel) and the total bias histories (gyro_bias, accel_bias)."""
        n = len(gyro)
        out = []
        for x, arw, b0, sig, sc in ((gyro, self.gyro_arw, self.gyro_turn_on_bias, self.gyro_instability,
                                     self.gyro_scale),
                                    (accel, self.accel_vrw, self.accel_turn_on_bias, self.accel_instability,
                                     self.accel_scale)):
            phi = math.exp(-dt / self.tau)
            drive_noise = rng.normal(0.0, sig * math.sqrt(1 - phi * phi), (n, 3))
            gm = np.empty((n, 3))
            gm[0] = rng.normal(0.0, sig, 3)
            for k in range(1, n):
                gm[k] = phi * gm[k - 1] + drive_noise[k]
            bias = rng.normal(0.0, b0, 3) + gm
            scale = 1.0 + rng.normal(0.0, sc, 3)
            out.append((x * scale + bias + rng.normal(0.0, arw / math.sqrt(dt), (n, 3)), bias))
        (g, gb), (a, ab) = out
        return g, a, gb, ab


@dataclass
class GnssGrade:
    """Receiver model: white noise + slow Gauss-Markov bias (DGPS), velocity noise, latency."""

    rate: float = 5.0
    sigma_h: float = 0.02
    sigma_v: float = 0.04
    bias_h: float = 0.0
    bias_tau: float = 300.0
    vel_sigma: float = 0.03
    latency: float = 0.1
    fix_type: int = 4


RTK_5HZ = GnssGrade()
DGPS_1HZ = GnssGrade(rate=1.0, sigma_h=0.05, sigma_v=0.10, bias_h=0.5, bias_tau=300.0, vel_sigma=0.05,
                     latency=0.05, fix_type=2)


def gnss_samples(traj, gyro_true, lever_frd, grade, rng):
    """Antenna fixes (epoch, arrival) with honest covariances from the truth and lever arm."""
    step = int(round(1.0 / (grade.rate * (traj.t[1] - traj.t[0]))))
    lever = np.asarray(lever_frd, dtype=float)
    phi = math.exp(-1.0 / (grade.rate * grade.bias_tau))
    bias = rng.normal(0.0, grade.bias_h, 2)
    out = []
    for k in range(step, len(traj.t) - 1, step):
        c = traj.c_b_ned[k]
        d = c @ lever
        rm, rn = earth.radii(traj.lat[k])
        bias = phi * bias + rng.normal(0.0, grade.bias_h * math.sqrt(1 - phi * phi), 2)
        e_n = d[:2] + bias + rng.normal(0.0, grade.sigma_h, 2)
        lat = traj.lat[k] + e_n[0] / (rm + traj.h[k])
        lon = traj.lon[k] + e_n[1] / ((rn + traj.h[k]) * math.cos(traj.lat[k]))
        alt = traj.h[k] - d[2] + rng.normal(0.0, grade.sigma_v)
        w = gyro_true[k] - c.T @ (earth.OMEGA * np.array([math.cos(traj.lat[k]), 0.0, -math.sin(traj.lat[k])]))
        v_ned = traj.v_ned[k] + c @ np.cross(w, lever) + rng.normal(0.0, grade.vel_sigma, 3)
        var_h = grade.sigma_h ** 2 + grade.bias_h ** 2
        out.append((traj.t[k] + grade.latency,
                    GnssSample(traj.t[k], lat, lon, alt, np.diag([var_h, var_h, grade.sigma_v ** 2]),
                               ENU_TO_NED.T @ v_ned, np.eye(3) * grade.vel_sigma ** 2, grade.fix_type)))
    return out


@dataclass
class RunErrors:
    """Per-IMU-sample errors of the IMU-point solution against the truth (after initialisation)."""

    t: np.ndarray
    pos: np.ndarray        # (N, 3) north, east, down [m]
    vel: np.ndarray        # (N, 3) NED [m/s]
    att: np.ndarray        # (N, 3) roll, pitch, heading [rad]
    pos_nees: np.ndarray   # 3-dof NEES of the position
    heading_sigma: np.ndarray
    pos_sigma: np.ndarray  # horizontal 1-sigma (sqrt of the trace) [m]


def run_ins(ekf, traj, gyro, accel, gnss, outages=(), every=10, imu_gaps=(), wheel=()):
    """Feed IMU, GNSS and wheel speeds (in arrival order, dropping epochs inside `outages` [(t0, t1)] and IMU samples
    inside `imu_gaps` [(t0, t1)]; wheel: (t, speed, variance) rows) to ekf; errors are sampled every `every` IMU
    samples."""
    n = len(gyro)
    rows = []
    gi = wi = 0
    roll, pitch, heading = traj.euler()
    for k in range(n):
        t = traj.t[k + 1]
        while gi < len(gnss) and gnss[gi][0] <= t:
            sample = gnss[gi][1]
            if not any(t0 <= sample.t < t1 for t0, t1 in outages):
                ekf.add_gnss(sample)
            gi += 1
        while wi < len(wheel) and wheel[wi][0] <= t:
            ekf.add_wheel(*wheel[wi])
            wi += 1
        if any(t0 <= t < t1 for t0, t1 in imu_gaps):
            continue
        ekf.add_imu(t, gyro[k], accel[k])
        sol = ekf.solution() if k % every == 0 else None
        if sol is None:
            continue
        rm, rn = earth.radii(sol.lat)
        e_ned = np.array([(sol.lat - traj.lat[k + 1]) * (rm + sol.h),
                          (sol.lon - traj.lon[k + 1]) * (rn + sol.h) * math.cos(sol.lat), traj.h[k + 1] - sol.h])
        cov = ENU_TO_NED @ sol.pos_cov_enu @ ENU_TO_NED.T
        att = np.array([sol.roll - roll[k + 1], sol.pitch - pitch[k + 1],
                        math.remainder(sol.heading - heading[k + 1], 2 * math.pi)])
        rows.append((t, e_ned, sol.v_ned - traj.v_ned[k + 1], att, float(e_ned @ np.linalg.solve(cov, e_ned)),
                     ekf.heading_sigma(), math.sqrt(np.trace(sol.pos_cov_enu[:2, :2]))))
    cols = list(zip(*rows))
    return RunErrors(*(np.array(c) for c in cols))


def field_drive(duration=240.0, speed=2.0, leg=40.0, heading0=0.3, tilt_deg=2.0):
    """Field passes with headland U-turns (speed-ups, 180° turns) and gentle terrain roll/pitch."""
    accel = 0.5
    segs = [(speed / accel, accel, 0.0)]
    total = segs[0][0]
    turn_rate = speed / 4.0                      # 8 m headland turn diameter
    sign = 1.0
    while total < duration:
        segs += [(leg / speed, 0.0, 0.0), (math.pi / turn_rate, 0.0, sign * turn_rate)]
        total += leg / speed + math.pi / turn_rate
        sign = -sign
    tilt = math.radians(tilt_deg)
    return drive(segs, heading0=heading0, tilt=lambda t: (tilt * math.sin(0.21 * t), 0.6 * tilt * math.sin(0.13 * t + 1)))
