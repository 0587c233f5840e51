"""Fixes moved from the antenna to base_link with the attitude of their epoch (SPEC §5.3, eq 4.18-4.24): the part of
/gnss/fix_corrected that gnss_correction_node (attitude from /odometry/filtered) and the navigation node (attitude
from its own states, no second 100 Hz subscription) share. Fixes without a position (status NO_FIX), with
non-finite values, a covariance that cannot be believed or a stamp off the stream's time are not corrected and are
counted; a fix waits up to `attitude_wait` s of node time for the attitude of its epoch.
"""
import bisect
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from agnav_common.frames import euler_from_quaternion, heading_from_yaw
from agnav_common.geodesy import offset_geodetic
from agnav_common.input_guard import StreamClock, covariance
from agnav_common.stamps import to_sec
from sensor_msgs.msg import NavSatFix, NavSatStatus

from agnav_fusion import tilt_correction


@dataclass
class FixCorrectionSettings:
    max_attitude_age: float = 0.5  # s between a fix epoch and the nearest attitude; farther: not corrected
    attitude_wait: float = 2.0     # s of node time a fix waits for the attitude of its epoch


class FixCorrection:
    """add_attitude() per state, add_fix() per /gnss/fix, process() now and then (node time passes): each corrected
    fix goes to emit(NavSatFix); count(event) hears every fix left uncorrected and why, and each "corrected"."""

    def __init__(self, settings, base_frame, lever, emit, count, now):
        """lever(): the base_link -> antenna translation (FLU, m), None while unknown; now(): node time (s)."""
        self.settings, self.base_frame = settings, base_frame
        self.lever, self.emit, self.count, self.now = lever, emit, count, now
        # (t, quaternion xyzw, roll/pitch/yaw variances); 30 s at 100 Hz: a fix delivered seconds
        # late (across processes DDS may resend a sample at its next heartbeat) still finds its epoch
        self.attitudes = deque(maxlen=3000)
        self.clock = StreamClock()
        self.pending = []  # (t, fix, covariance, known, node arrival time) waiting for the attitude of their epoch

    def add_attitude(self, t, quat, variances):
        if all(map(math.isfinite, quat)):
            self.attitudes.append((t, quat, variances))
            if self.pending:
                self.process()

    def add_fix(self, msg):
        t = to_sec(msg.header.stamp)
        if msg.status.status < NavSatStatus.STATUS_FIX:
            self.count("no_fix")
            return
        if not all(map(math.isfinite, (msg.latitude, msg.longitude, msg.altitude))):
            self.count("bad_value")
            return
        known = msg.position_covariance_type != NavSatFix.COVARIANCE_TYPE_UNKNOWN
        cov, problem = covariance(np.reshape(msg.position_covariance, (3, 3))) if known else (np.zeros((3, 3)), None)
        if cov is None:
            self.count(problem)
            return
        reason = self.clock.check(t)
        if reason:
            self.count(reason)
            return
        # corrected at the next attitude or process(), not here: a fix arrives after the IMU sample of its epoch,
        # whose state is being published
        self.pending.append((t, msg, cov, known, self.now()))

    def process(self):
        """Correct the waiting fixes whose epoch the attitude stream has reached (the attitude may arrive after the
        fix), or that have waited attitude_wait s of node time."""
        s = self.settings
        latest = self.attitudes[-1][0] if self.attitudes else -math.inf
        while self.pending and (self.pending[0][0] <= latest or self.now() - self.pending[0][4] > s.attitude_wait):
            t, msg, cov, known, _ = self.pending.pop(0)
            att = self.nearest_attitude(t)
            if att is None or abs(att[0] - t) > s.max_attitude_age:
                self.count("no_attitude")
            else:
                self.correct(msg, cov, known, att)

    def nearest_attitude(self, t):
        if not self.attitudes:
            return None
        i = bisect.bisect_left(self.attitudes, t, key=lambda a: a[0])
        return min((self.attitudes[j] for j in (i - 1, i) if 0 <= j < len(self.attitudes)), key=lambda a: abs(a[0] - t))

    def correct(self, msg, cov, known, att):
        mount = self.lever()
        if mount is None:
            self.count("no_tf")
            return
        _, quat, (v_roll, v_pitch, v_yaw) = att
        roll, pitch, yaw = euler_from_quaternion(*quat)
        heading, pitch = float(heading_from_yaw(yaw)), -pitch  # thesis conventions: heading, pitch nose-up
        lever = tilt_correction.lever_from_flu(mount)
        offset = tilt_correction.antenna_offset(lever, heading, pitch, roll)  # ENU, eq 4.23
        lat, lon, alt = offset_geodetic(msg.latitude, msg.longitude, msg.altitude, *(-offset))  # eq 4.24
        out = NavSatFix(status=msg.status)  # a header of its own: the input's may be shared with other subscribers
        out.header.stamp, out.header.frame_id = msg.header.stamp, self.base_frame
        out.latitude, out.longitude, out.altitude = float(lat), float(lon), float(alt)
        if known:  # an unknown covariance stays unknown
            tilt_var = tilt_correction.tilt_variance(lever, v_roll, v_pitch, v_yaw)
            out.position_covariance = [float(v) for v in (cov + np.diag([tilt_var, tilt_var, 0.0])).ravel()]
            out.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN
        self.emit(out)
        self.count("corrected")
