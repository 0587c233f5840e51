"""Absolute heading from the GDS (fluxgate) or GNSS with a yaw gyro (SPEC §3–§5; issue 5).

Subscribes
  /imu/mag (sensor_msgs/MagneticField, tesla, mag_link), /imu/data_raw (sensor_msgs/Imu, gyro),
  /imu/data (sensor_msgs/Imu, roll/pitch; tilt_source=imu_data) or /inclinometer (agnav_msgs/Inclination,
  denoised by the ALE; tilt_source=inclinometer), /gnss/fix (declination at the fix, GNSS estimator, speed).
Publishes
  /heading/imu (sensor_msgs/Imu, frame base_link): orientation = REP-103 roll, pitch (from the tilt source) and
  ENU yaw = π/2 − φ_true (SPEC §2.3) with the estimator's yaw variance in orientation_covariance[8]
  (roll/pitch variances from the tilt source, 99999 when unknown); angular_velocity = base_link gyro rates with
  the estimated yaw drift removed (covariance unknown: [0] = -1); linear_acceleration_covariance[0] = -1.
  Stamp = the heading's epoch. /diagnostics: inputs rejected and GDS samples flagged in the last
  `diagnostics.window` s (agnav_common.input_guard.EventWindow), stale streams, declination source, disturbance.
Parameter `estimator`: gds_kf (§3.5) | vwa (§3.6) | gds_gyro_lsm (§4.5–4.7) | gnss_gyro_lsm (§5.1–5.2).
Magnetic disturbance (heading_gate), decided when a GDS sample arrives (with the newest tilt, so that the flag
does not wait for the ALE-delayed tilt): its intensity or inclination is off the WMM value, or its heading
disagrees with the integrated gyro (innovation test). A flagged sample is not fused; the heading follows the gyro
alone with a growing variance (gyro.*) and /diagnostics is WARN until the gate reopens.
Parameters: HeadingNodeSettings below (gate: disturbance.*, gyro.*), documented in config/heading_node.yaml.
Input stamps: one agnav_common.input_guard.StreamClock per stream (a lone future stamp is rejected, never
moves the stream's time).
"""
import math
from collections import deque
from dataclasses import replace

import numpy as np
from agnav_common.diagnostics import ERROR, OK, WARN, Diagnostics
from agnav_common.frames import euler_from_quaternion, quaternion_from_euler, yaw_from_heading
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.input_guard import EventWindow, StreamClock, StreamClockSettings, finite
from agnav_common.node_main import main_for
from agnav_common.parameters import declare, leaves
from agnav_common.qos import PUBLISHER_QOS, subscribe_input
from agnav_common.stamps import to_sec, to_stamp
from agnav_common.tf import TfBuffer
from agnav_msgs.msg import Inclination
from rclpy.node import Node
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import Imu, MagneticField, NavSatFix

from agnav_fusion.adaptive_line_enhancer import AdaptiveLineEnhancer, AleSettings
from agnav_fusion.gds_heading import CircleCalibration, inclination, magnetic_heading, tilt_compensate
from agnav_fusion.geomagnetic_model import DisturbanceSettings, MagneticModel, disturbance
from agnav_fusion.heading_estimators import EstimatorSettings, HeadingEstimator
from agnav_fusion.heading_gate import GateSettings, GyroErrorSettings, MagneticGate
from agnav_fusion.heading_node_settings import ALE_INTERNAL, HeadingNodeSettings
from agnav_common.variance_weighted_average import VwaSettings

UNKNOWN_VARIANCE = 99999.0
MAX_GYRO_GAP = 0.5   # s; longer gaps restart the gyro integration step


def parameter_entries():
    """[(name, default, description)] of every parameter (tools/gen_params.py writes the params file from it)."""
    return leaves(HeadingNodeSettings(), skip=ALE_INTERNAL)


class HeadingNode(Node):
    def __init__(self, **kwargs):
        super().__init__("heading_node", **kwargs)
        s = declare(self, HeadingNodeSettings(), skip=ALE_INTERNAL)
        self.base_frame = s.base_frame
        self.tilt_source = s.tilt_source
        if self.tilt_source not in ("imu_data", "inclinometer", "none"):
            raise ValueError("tilt_source must be imu_data | inclinometer | none")
        self.cal = CircleCalibration(np.array(s.mag.center, float), np.array(s.mag.soft_iron, float).reshape(2, 2),
                                     z_offset=s.mag.z_offset)
        self.ale = (AdaptiveLineEnhancer(s.ale), AdaptiveLineEnhancer(s.ale))
        self.incl_rate = s.inclinometer_rate
        default_delay = self.ale[0].delay_samples() / self.incl_rate if self.tilt_source == "inclinometer" else 0.0
        self.tilt_delay = default_delay if s.gds_delay < 0 else s.gds_delay
        self.site = list(s.declination_site)   # [lat, lon, alt] used before the first fix
        self.wmm = MagneticModel(fallback_year=s.wmm_fallback_year or None)
        d, deg = s.disturbance, math.radians
        self.dist = DisturbanceSettings(d.intensity_tolerance, deg(d.inclination_tolerance_deg))
        gyro = GyroErrorSettings(deg(s.gyro.bias_sigma_deg_s), deg(s.gyro.arw_deg_sqrt_s),
                                 deg(s.gyro.bias_walk_deg_s_sqrt_s))
        self.gate = MagneticGate(GateSettings(k_sigma=d.innovation_k_sigma, reference_window=d.reference_window,
                                              recover_time=d.recover_time,
                                              offset_sigma_floor=deg(d.offset_sigma_floor_deg), gyro=gyro))
        est = EstimatorSettings()
        self.settings = replace(
            est, estimator=s.estimator, kf=replace(est.kf, drift_noise=s.kf.drift_noise),
            vwa=VwaSettings(s.vwa.window, s.vwa.interval), lsm_window_s=s.lsm.window,
            lsm_vwa=VwaSettings(s.lsm.vwa_window, s.lsm.vwa_interval), gds_delay_s=self.tilt_delay,
            imu_rate_hz=s.imu_rate, nominal_speed=s.nominal_speed,
            gds_systematic_sigma=deg(s.gds.systematic_sigma_deg), gyro=gyro)
        self.estimator = HeadingEstimator(self.settings)
        self.stale_timeout = s.stale_timeout
        clock = StreamClockSettings(max_jump=s.stamp_max_jump)
        self.clocks = {k: StreamClock(clock) for k in ("gyro", "mag", "tilt", "fix")}
        self.events = EventWindow(s.diagnostics.window)   # rejections and flagged GDS samples
        self.last_seen = {}
        self.tilt = deque(maxlen=500)            # (epoch, roll_thesis, pitch_thesis, var_roll, var_pitch)
        self.pending_mag = deque(maxlen=200)     # (t, b_thesis) waiting for tilt at their epoch
        self.fix = None                          # (lat, lon, alt)
        self.plane = None
        self.field_error = (0.0, 0.0)
        self.published = 0
        self.last_heading = None
        self._gyro_t = None
        self._rates = np.zeros(3)
        self.tf = TfBuffer(self)

        self.pub = self.create_publisher(Imu, "heading/imu", PUBLISHER_QOS)
        subscribe_input(self, Imu, "imu/data_raw", self._on_gyro)
        subscribe_input(self, MagneticField, "imu/mag", self._on_mag)
        subscribe_input(self, NavSatFix, "gnss/fix", self._on_fix)
        if self.tilt_source == "imu_data":
            subscribe_input(self, Imu, "imu/data", self._on_imu_data)
        elif self.tilt_source == "inclinometer":
            subscribe_input(self, Inclination, "inclinometer", self._on_inclinometer)
        self.diagnostics = Diagnostics(self, "heading")
        self.diagnostics.add("heading", self._diagnose)

    # ---- input helpers ------------------------------------------------------------------------------------
    @property
    def now(self):
        """Stream time: the newest accepted input stamp (the time base of the event window)."""
        return max(self.last_seen.values(), default=0.0)

    def _reject(self, reason):
        self.events.add(reason, self.now)

    def _accept(self, stream, stamp, values):
        t = to_sec(stamp)
        if not finite(values):
            self._reject("non_finite")
            return None
        reason = self.clocks[stream].check(t)
        if reason is not None:
            self._reject(reason)
            return None
        self.last_seen[stream] = t
        return t

    def _to_base(self, frame_id, vec):
        tf = self.tf.lookup(self.base_frame, frame_id or self.base_frame)
        if tf is None:
            self._reject("no_tf")
            return None
        return Rotation.from_quat(tf[1]).apply(vec)

    # ---- callbacks ----------------------------------------------------------------------------------------
    def _on_gyro(self, msg: Imu):
        w = msg.angular_velocity
        t = self._accept("gyro", msg.header.stamp, (w.x, w.y, w.z))
        if t is None:
            return
        rates = self._to_base(msg.header.frame_id, [w.x, w.y, w.z])
        if rates is None:
            return
        dt = t - self._gyro_t if self._gyro_t is not None and t - self._gyro_t < MAX_GYRO_GAP else 0.0
        self._gyro_t, self._rates = t, rates
        out = self.estimator.on_gyro(t, -rates[2], dt)
        if out is not None and dt > 0.0:
            self._publish(*out)

    def _on_imu_data(self, msg: Imu):
        q = msg.orientation
        t = self._accept("tilt", msg.header.stamp, (q.x, q.y, q.z, q.w))
        if t is None:
            return
        roll, pitch, _ = euler_from_quaternion(q.x, q.y, q.z, q.w)
        cov = msg.orientation_covariance
        self._add_tilt(t, roll, pitch, cov[0], cov[4])

    def _on_inclinometer(self, msg: Inclination):
        t = self._accept("tilt", msg.header.stamp, (msg.roll, msg.pitch))
        if t is None:
            return
        roll, pitch = self.ale[0].update(msg.roll), self.ale[1].update(msg.pitch)
        self._add_tilt(t - self.tilt_delay, roll, pitch, msg.roll_variance, msg.pitch_variance)

    def _add_tilt(self, epoch, roll, pitch, var_roll, var_pitch):
        """Store tilt in thesis convention (pitch nose up) and release the GDS samples it now covers."""
        self.tilt.append((epoch, roll, -pitch, var_roll, var_pitch))
        while self.pending_mag and self.pending_mag[0][0] <= epoch:
            self._process_mag(*self.pending_mag.popleft())

    def _on_mag(self, msg: MagneticField):
        f = msg.magnetic_field
        t = self._accept("mag", msg.header.stamp, (f.x, f.y, f.z))
        if t is None:
            return
        b = self._to_base(msg.header.frame_id, [f.x, f.y, f.z])
        if b is None:
            return
        b_thesis = self.cal.apply(np.array([-b[1], b[0], b[2]]))
        expected = self._expected_field(t)
        if expected is None:
            self._reject("no_declination")
            return
        disturbed = self._check_gds(t, b_thesis, expected)
        if self.tilt_source == "none" or (self.tilt and self.tilt[-1][0] >= t):
            self._process_mag(t, b_thesis, expected, disturbed)
        else:
            self.pending_mag.append((t, b_thesis, expected, disturbed))

    def _check_gds(self, t, b_thesis, expected):
        """Disturbance flag of a GDS sample on arrival, with the newest tilt (field check, innovation test)."""
        tilt = (0.0, 0.0) if self.tilt_source == "none" else (self.tilt[-1][1:3] if self.tilt else None)
        level = None if tilt is None else tilt_compensate(b_thesis, *tilt)
        field_bad, *self.field_error = disturbance(float(np.linalg.norm(b_thesis)),
                                                   None if level is None else float(inclination(level)),
                                                   expected, self.dist)
        gyro = self.estimator.gyro.at(t, extrapolate=True, corrected=True)
        if level is None or gyro is None:    # no heading to test yet: the field check alone
            disturbed = field_bad
        else:
            heading = float(magnetic_heading(level)) + expected.declination
            disturbed = self.gate.update(t, heading, gyro, field_bad)
        if disturbed:
            self.events.add("disturbed_gds", self.now)
        return disturbed

    def _tilt_at(self, t):
        if self.tilt_source == "none":
            return 0.0, 0.0
        if not self.tilt or t < self.tilt[0][0]:
            return None
        ts = np.array([s[0] for s in self.tilt])
        return (float(np.interp(t, ts, [s[1] for s in self.tilt])), float(np.interp(t, ts, [s[2] for s in self.tilt])))

    def _process_mag(self, t, b_thesis, expected, disturbed):
        tilt = self._tilt_at(t)
        if tilt is None:
            self._reject("no_tilt")
            return
        heading = float(magnetic_heading(tilt_compensate(b_thesis, *tilt))) + expected.declination
        out = self.estimator.on_gds(t, heading, disturbed)
        if out is not None:
            self._publish(*out)

    def _expected_field(self, t):
        site = self.fix or (tuple(self.site) if len(self.site) == 3 else None)
        return None if site is None else self.wmm.at(*site, t)

    def _on_fix(self, msg: NavSatFix):
        t = self._accept("fix", msg.header.stamp, (msg.latitude, msg.longitude, msg.altitude))
        if t is None or msg.status.status < 0:
            return
        self.fix = (msg.latitude, msg.longitude, msg.altitude)
        if self.plane is None:
            self.plane = LocalTangentPlane(*self.fix)
        e, n, _ = self.plane.to_enu(*self.fix)
        cov = msg.position_covariance
        var = 0.5 * (cov[0] + cov[4]) if msg.position_covariance_type > 0 else 1.0
        self.estimator.on_fix(t, float(e), float(n), var)

    # ---- output -------------------------------------------------------------------------------------------
    def _publish(self, t, heading, variance):
        if not (math.isfinite(heading) and math.isfinite(variance)):
            self._reject("non_finite_output")
            return
        tilt = self._tilt_at(t) if self.tilt_source != "none" else None
        roll, pitch_up = tilt if tilt is not None else (0.0, 0.0)
        last = self.tilt[-1] if self.tilt else None
        var_rp = (last[3], last[4]) if last is not None and last[3] > 0 else (UNKNOWN_VARIANCE, UNKNOWN_VARIANCE)
        msg = Imu()
        msg.header.stamp = to_stamp(t)
        msg.header.frame_id = self.base_frame
        q = quaternion_from_euler(roll, -pitch_up, float(yaw_from_heading(heading)))
        msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = q
        msg.orientation_covariance = [var_rp[0], 0.0, 0.0, 0.0, var_rp[1], 0.0, 0.0, 0.0, float(variance)]
        wx, wy, wz = (float(v) for v in self._rates)
        msg.angular_velocity.x, msg.angular_velocity.y = wx, wy
        msg.angular_velocity.z = wz - self.estimator.drift      # ω_z = −(r + d)
        msg.angular_velocity_covariance[0] = -1.0
        msg.linear_acceleration_covariance[0] = -1.0
        self.pub.publish(msg)
        self.published += 1
        self.last_heading = (t, heading, variance)

    def _diagnose(self):
        now = self.now
        uses_gds = self.settings.estimator != "gnss_gyro_lsm"
        needed = ["gyro"] + (["mag"] if uses_gds else ["fix"])
        if self.tilt_source != "none" and uses_gds:
            needed.append("tilt")
        stale = [k for k in needed if now - self.last_seen.get(k, -math.inf) > self.stale_timeout]
        recent = self.events.recent(now)
        flagged = recent.pop("disturbed_gds", 0)
        gate = self.gate
        values = {"estimator": self.settings.estimator, "published": self.published,
                  "window_s": self.events.window, **{f"rejected_{k}": v for k, v in sorted(recent.items())},
                  "disturbed_gds_samples": flagged, "gds_disturbed": gate.disturbed,
                  "field_intensity_error": f"{self.field_error[0]:.3f}",
                  "field_inclination_error_deg": f"{math.degrees(self.field_error[1]):.2f}",
                  "gds_gyro_innovation_deg": f"{math.degrees(gate.innovation):.2f}",
                  "gds_gyro_innovation_sigma_deg": f"{math.degrees(gate.sigma):.2f}",
                  "declination_source": "fix" if self.fix else ("site" if len(self.site) == 3 else "none"),
                  "gyro_drift_deg_s": f"{math.degrees(self.estimator.drift):.4f}"}
        if self.last_heading:
            values["heading_std_deg"] = f"{math.degrees(math.sqrt(self.last_heading[2])):.3f}"
        if stale:
            return ERROR, f"stale: {', '.join(stale)}", values
        if uses_gds and gate.disturbed:
            cause = ("field strength/inclination off the WMM value" if gate.reason == "field"
                     else "GDS heading disagrees with the gyro")
            return WARN, f"magnetic disturbance ({cause}): GDS not fused, gyro-only heading", values
        if uses_gds and values["declination_source"] == "none":
            return WARN, "no fix/site for the WMM declination: GDS heading withheld", values
        if recent:
            return WARN, f"inputs rejected in the last {self.events.window:g} s: " + ", ".join(
                f"{k} {v}" for k, v in sorted(recent.items())), values
        return OK, "ok", values


main = main_for(HeadingNode)
