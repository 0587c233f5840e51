"""The navigation pipeline: front end + estimator backend, driven by the sensor messages themselves. ROS-free.

nav_sensor_module_node, the offline replay of a bag (agnav_fusion.bag_replay), the closed-loop simulation and the
benchmarks all call the same `on_*` methods with the same messages (rclpy messages in the node, rosbags messages
offline: the same fields), so what a benchmark measures is what the node publishes.

Front end (what every estimator needs once):
- mounts: the IMU rotation into base_link, GNSS and inclinometer lever arms (from TF in the node, /tf_static
  offline), set once by `set_mounts`; nothing is used before them;
- the map datum: the `datum` setting or the first good fix; geodetic fixes -> map ENU;
- NO_FIX and impossible fixes never reach the estimator; a covariance of type UNKNOWN becomes `unknown_fix_sigma`;
- fix/velocity epoch pairing: a receiver publishes /gnss/fix before the /gnss/vel of the same epoch, so once a
  velocity has been seen a fix waits for its own up to `velocity_wait` s of IMU time; without /gnss/vel the
  velocity of the fixes over the last `fix_velocity_baseline` m (at most FIX_HISTORY_S back) is used (not for a
  strapdown backend: the INS differences its own fixes, ins.alignment.FixTrack);
- the gyro's first-order response (`gyro_bandwidth_hz`) undone (gyro_lag);
- the tilt source: inclinometer messages, or the accelerometer's gravity direction (`tilt_source: accelerometer`).
The backend (NavSensorModule: estimator `agnav` or `thesis`; InsNavigation: `ins`) guards values and stamps,
replays late fixes against its IMU history and keeps the covariances. Every backend gets the accelerometer's
specific force in base_link axes (None when the message says it has none: covariance[0] = -1, REP-145, or when
the accelerometer is the tilt source of a non-strapdown backend: its tilt then already holds the acceleration). A
`strapdown` backend (the INS integrates specific force at the IMU point, on the earth) needs it (an IMU message
without one is counted `imu_no_accel`) and also gets the base_link -> imu_link translation, the map plane and the 3x3 ENU covariance of
/gnss/vel (None: unknown) in place of its per-axis horizontal variance.
A `raw_gnss` backend (InsTightNavigation: `ins_tight`) also gets the receiver's RTK status (/gnss/status) and raw
epochs: rover and base agnav_msgs/GnssObservations, the base ECEF position (PointStamped) and the GnssNavData frames
are gathered by gnss_raw.raw_input.RawInput; a rover epoch goes to the backend with the latest base epoch once the
IMU has reached its stamp (at once when it arrives after that IMU sample).
"""
import math
from dataclasses import dataclass

import numpy as np
from agnav_common.geodesy import LocalTangentPlane

from agnav_fusion.gyro_lag import GyroLag

VEL_MATCH_S = 0.1       # s, a /gnss/vel within this of a fix epoch is fused with it ...
VEL_MATCH_PERIODS = 0.25  # ... and within this share of the fix interval (a 10 Hz fix never takes the last epoch's)
FIX_HISTORY_S = 10.0    # s of fixes kept for the fix-difference velocity (slow 10 Hz runs still reach the baseline)
STATUS_FIX = 0      # sensor_msgs/NavSatStatus: below this there is no position
FIX_RTK_FIXED = 4   # agnav_msgs/GnssStatus.fix_type
COVARIANCE_TYPE_UNKNOWN = 0


def stamp_seconds(header):
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def rotate(rows, v):
    """The rotation matrix `rows` (3 tuples of floats) times the Vector3 v, as an array (the matrix product on
    floats: a third of numpy's cost for one vector)."""
    (a, b, c), (d, e, f), (g, h, i) = rows
    x, y, z = v.x, v.y, v.z
    return np.array([a * x + b * y + c * z, d * x + e * y + f * z, g * x + h * y + i * z])


def accelerometer_tilt(f):
    """REP-103 (roll, pitch) of the specific force f (base_link FLU, m/s^2; +g up at rest)."""
    return math.atan2(f[1], f[2]), math.atan2(-f[0], math.hypot(f[1], f[2]))


@dataclass
class FrontEndSettings:
    datum: tuple = (0.0,)               # [lat deg, lon deg, ellipsoidal alt m]; shorter: the first good fix
    tilt_source: str = "inclinometer"   # inclinometer | accelerometer (/imu/data_raw)
    velocity_wait: float = 0.2          # s of IMU time a fix waits for its /gnss/vel
    fix_velocity_baseline: float = 2.0  # m; 0: no velocity without /gnss/vel (the INS: its own 2 m FixTrack)
    unknown_fix_sigma: float = 1.0      # m per axis of a fix whose covariance type is UNKNOWN
    gyro_bandwidth_hz: float = 0.0      # Hz, the gyro's first-order response (data sheet), undone; 0: taken as is


class NavigationPipeline:
    """on_imu / on_inclinometer / on_fix / on_velocity / on_wheel(msg); on_imu returns the new state (None when the
    sample was not used); ready(state): heading and position initialised, the state is published.
    `on_datum(lat, lon, alt, stamp)` is called when the datum is set."""

    def __init__(self, backend, settings=None, on_datum=None):
        self.settings = s = settings or FrontEndSettings()
        if s.tilt_source not in ("inclinometer", "accelerometer"):
            raise ValueError(f"tilt_source must be inclinometer or accelerometer, not {s.tilt_source!r}")
        self.backend = backend
        self.guard = backend.guard
        self.strapdown = getattr(backend, "strapdown", False)
        self.on_datum = on_datum
        self.gyro_lag = GyroLag(s.gyro_bandwidth_hz)
        self.imu_rotation = None
        self._rotation_rows = None  # imu_rotation as rows of floats (per-sample rotation, rotate())
        self.plane = None
        self.velocities = []     # (t, ENU velocity, variance or None) of recent /gnss/vel
        self.pending_fixes = []  # (t, enu, cov, deadline) waiting for their velocity
        self.recent_fixes = []   # (t, enu, cov) for the fix-difference velocity
        self.fix_interval = math.inf  # s between the last two fix epochs
        self.last_fix_t = None
        self.last_imu_t = 0.0
        self.raw = None
        if getattr(backend, "raw_gnss", False):   # cssrlib is imported only for such a backend
            from agnav_fusion.gnss_raw.raw_input import RawInput
            self.raw = RawInput()
        self.pending_raw = []    # (stamp, rover ObsEpoch) waiting for the IMU to reach the stamp
        self.imu_stamp = -math.inf
        self.configured_datum = len(s.datum) >= 3
        if self.configured_datum:
            self._set_plane(LocalTangentPlane(*(float(v) for v in s.datum[:3])))

    def start(self):
        """Announce a configured datum (call once the consumer of on_datum is ready)."""
        if self.configured_datum and self.on_datum:
            self.on_datum(*self.settings.datum[:3], None)

    def set_mounts(self, imu_rotation, gnss_lever, incl_lever, imu_lever=(0.0, 0.0, 0.0)):
        """base_link <- imu_link rotation (3x3) and the base_link -> gnss_link / inclinometer_link (/ imu_link)
        translations."""
        self.imu_rotation = np.asarray(imu_rotation, dtype=float)
        self._rotation_rows = tuple(map(tuple, self.imu_rotation.tolist()))
        self.backend.set_mounts(gnss_lever, incl_lever, *((imu_lever,) if self.strapdown else ()))

    def _set_plane(self, plane):
        self.plane = plane
        if self.strapdown:
            self.backend.set_plane(plane)

    def _set_datum(self, lat, lon, alt, stamp):
        self._set_plane(LocalTangentPlane(float(lat), float(lon), float(alt)))
        if self.on_datum:
            self.on_datum(lat, lon, alt, stamp)

    # ---- inputs -----------------------------------------------------------------------------------------
    def on_imu(self, msg):
        if self.strapdown and msg.linear_acceleration_covariance[0] == -1.0:  # REP-145: no accelerometer here
            self.guard.count("imu_no_accel")
            return None
        if self.imu_rotation is None:
            self.guard.count("missing_tf")
            return None
        t = stamp_seconds(msg.header)
        if self.pending_fixes:
            self._submit_fixes(lambda fix: fix[3] < t)
        # REP-145: covariance[0] -1 = no accelerometer; every backend gets the specific force (None without one)
        rows = self._rotation_rows
        accel = None if msg.linear_acceleration_covariance[0] == -1.0 else rotate(rows, msg.linear_acceleration)
        if self.settings.tilt_source == "accelerometer" and accel is not None:
            self.backend.inclinometer(t, *accelerometer_tilt(accel))
            if not self.strapdown:  # its tilt already holds the acceleration: no second, independent use of it
                accel = None
        state = self.backend.imu(t, self.gyro_lag.undo(t, rotate(rows, msg.angular_velocity)), accel)
        if state is not None:
            self.last_imu_t = max(self.last_imu_t, state.t)
        if self.raw is not None:
            self.imu_stamp = max(self.imu_stamp, t)
            self._submit_raw()
        return state

    @staticmethod
    def ready(state):
        """Like robot_localization, nothing is published before heading and position are initialised."""
        return state.heading_valid and state.position_valid

    def on_inclinometer(self, msg):
        if self.settings.tilt_source == "inclinometer":
            self.backend.inclinometer(stamp_seconds(msg.header), msg.roll, msg.pitch)

    def on_wheel(self, msg):
        var = msg.twist.covariance[0]  # 0 or -1: unknown (the module's wheel_speed_sigma); negative/NaN: rejected
        var = None if var in (0.0, -1.0) else (var if var > 0 else math.nan)
        self.backend.wheel_speed(stamp_seconds(msg.header), msg.twist.twist.linear.x, var)

    def on_velocity(self, msg):
        v, c = msg.twist.twist.linear, msg.twist.covariance
        # -1: unknown (the module's velocity_sigma); NaN or a negative variance: the velocity is dropped, counted
        if c[0] == -1.0:
            var = None
        elif self.strapdown:
            var = np.asarray(c, dtype=float).reshape(6, 6)[:3, :3]
        else:
            var = (c[0] + c[7]) / 2 if c[0] >= 0 and c[7] >= 0 else math.nan
        self.velocities = (self.velocities + [(stamp_seconds(msg.header), np.array([v.x, v.y, v.z]), var)])[-10:]
        self._submit_fixes(lambda fix: self._velocity_at(fix[0]) is not None)

    def on_fix(self, msg):
        if msg.status.status < STATUS_FIX:
            self.guard.count("gnss_no_fix")
            return
        lat, lon, alt = msg.latitude, msg.longitude, msg.altitude
        if not (np.all(np.isfinite([lat, lon, alt])) and abs(lat) <= 90.0 and abs(lon) <= 180.0):
            self.guard.count("gnss_bad_value")
            return
        if self.plane is None:
            self._set_datum(lat, lon, alt, msg.header.stamp)
        t = stamp_seconds(msg.header)
        if self.last_fix_t is not None and t > self.last_fix_t:
            self.fix_interval = t - self.last_fix_t
        self.last_fix_t = t
        enu = np.array(self.plane.to_enu(lat, lon, alt), dtype=float)
        if msg.position_covariance_type == COVARIANCE_TYPE_UNKNOWN:
            cov = np.eye(3) * self.settings.unknown_fix_sigma ** 2
        else:
            cov = np.array(msg.position_covariance, dtype=float).reshape(3, 3)
        self.pending_fixes.append((t, enu, cov, self.last_imu_t + self.settings.velocity_wait))
        if not (self.velocities and self.settings.velocity_wait > 0 and self._velocity_at(t) is None):
            self._submit_fixes(lambda fix: True)

    # ---- raw GNSS (a raw_gnss backend) ----------------------------------------------------------------------
    def on_status(self, msg):
        self.backend.receiver_status(stamp_seconds(msg.header), msg.fix_type == FIX_RTK_FIXED)

    def on_base_position(self, msg):
        self.raw.base_position(msg.point.x, msg.point.y, msg.point.z)

    def on_nav_data(self, msg):
        self.raw.nav_data(msg)

    def on_base_observations(self, msg):
        self.raw.observations(msg, "base")

    def on_raw_observations(self, msg):
        self.pending_raw.append((stamp_seconds(msg.header), self.raw.observations(msg, "rover")))
        self._submit_raw()

    def _submit_raw(self):
        while self.pending_raw and self.pending_raw[0][0] <= self.imu_stamp:
            rover = self.pending_raw.pop(0)[1]
            self.backend.raw_epoch(rover, self.raw.base, self.raw.nav, self.raw.base_pos)

    # ---- fix / velocity pairing -----------------------------------------------------------------------
    def _velocity_at(self, t):
        """(ENU velocity, its variance or None) of the /gnss/vel nearest the fix epoch t within VEL_MATCH_S and
        VEL_MATCH_PERIODS fix intervals, else None."""
        near = min(self.velocities, key=lambda tv: abs(tv[0] - t), default=None)
        tolerance = min(VEL_MATCH_S, VEL_MATCH_PERIODS * self.fix_interval)
        return near[1:] if near is not None and abs(near[0] - t) <= tolerance else None

    def _fix_velocity(self, t, enu, cov):
        """(ENU velocity, per-axis variance) from the latest earlier fix at least fix_velocity_baseline m away
        (variance: both fixes' horizontal variances over the time squared), else None."""
        base = next(((t0, p0, c0) for t0, p0, c0 in reversed(self.recent_fixes)
                     if t0 < t and np.hypot(*(enu[:2] - p0[:2])) >= self.settings.fix_velocity_baseline), None)
        self.recent_fixes = [f for f in self.recent_fixes if f[0] >= t - FIX_HISTORY_S] + [(t, enu, cov)]
        if base is None or self.settings.fix_velocity_baseline <= 0:
            return None
        dt = t - base[0]
        return (enu - base[1]) / dt, float(np.trace(cov[:2, :2]) + np.trace(base[2][:2, :2])) / 2 / dt ** 2

    def _submit_fixes(self, due):
        """Hand the pending fixes up to the last due one to the backend, in epoch order."""
        last = max((i for i, fix in enumerate(self.pending_fixes) if due(fix)), default=-1)
        for t, enu, cov, _ in self.pending_fixes[:last + 1]:
            vel = (self._velocity_at(t) if self.velocities
                   else None if self.strapdown else self._fix_velocity(t, enu, cov))
            self.backend.gnss(t, enu, cov, *(vel or ()))
        del self.pending_fixes[:last + 1]
