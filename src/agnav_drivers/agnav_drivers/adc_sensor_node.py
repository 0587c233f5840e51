"""Analog sensor ADC driver node: microcontroller frames over serial -> /imu/data_raw (vibratory
gyros, accelerometers if wired), /inclinometer, /imu/mag, /diagnostics; service
~/calibrate_gyro (std_srvs/Trigger) re-measures V_static at standstill. Conversions live in adc.py."""
from __future__ import annotations

import math

from sensor_msgs.msg import Imu, MagneticField
from std_srvs.srv import Trigger

from agnav_common.diagnostics import OK, WARN
from agnav_common.node_main import main_for
from agnav_common.qos import PUBLISHER_QOS
from agnav_msgs.msg import Inclination

from .adc import AdcConverter, AdcDecoder, AdcSettings
from .stream_driver import StreamDriverNode


class AdcSensorNode(StreamDriverNode):
    def __init__(self, **kwargs):
        super().__init__("adc_sensor", "adc_sensor", default_baud=115200, stale_timeout=0.5, **kwargs)
        p = self.declare_parameter
        d = AdcSettings()
        self.converter = AdcConverter(AdcSettings(
            vref=p("vref", d.vref).value, bits=p("bits", d.bits).value, channels=list(p("channels", d.channels).value),
            gyro_scale=tuple(p("gyro_scale", list(d.gyro_scale)).value),
            static_samples=p("static_samples", d.static_samples).value,
            static_max_std=p("static_max_std", d.static_max_std).value,
            incl_zero=tuple(p("incl_zero", list(d.incl_zero)).value),
            incl_sensitivity=tuple(p("incl_sensitivity", list(d.incl_sensitivity)).value),
            incl_sign=tuple(p("incl_sign", list(d.incl_sign)).value),
            mag_zero=tuple(p("mag_zero", list(d.mag_zero)).value),
            mag_scale=tuple(p("mag_scale", list(d.mag_scale)).value),
            accel_zero=tuple(p("accel_zero", list(d.accel_zero)).value),
            accel_scale=tuple(p("accel_scale", list(d.accel_scale)).value)))
        self.decoder = AdcDecoder(p("frame_mode", "binary").value)
        self.imu_frame = p("imu_frame_id", "imu_link").value
        self.incl_frame = p("inclinometer_frame_id", "inclinometer_link").value
        self.mag_frame = p("mag_frame_id", "mag_link").value
        self.gyro_var = math.radians(p("gyro_noise", 0.4).value) ** 2        # (deg/s rms)^2 -> (rad/s)^2
        self.accel_var = p("accel_noise", 0.05).value ** 2                    # (m/s^2)^2
        self.incl_var = math.radians(p("incl_noise", 0.5).value) ** 2         # deg rms -> rad^2
        self.mag_var = (p("mag_noise", 1.25).value * 1e-7) ** 2               # mG rms -> T^2
        self.imu_pub = self.create_publisher(Imu, "imu/data_raw", PUBLISHER_QOS)
        self.incl_pub = self.create_publisher(Inclination, "inclinometer", PUBLISHER_QOS)
        self.mag_pub = self.create_publisher(MagneticField, "imu/mag", PUBLISHER_QOS)
        self.create_service(Trigger, "~/calibrate_gyro", self._calibrate)
        self.diagnostics.add("adc", self._check)
        self.diagnostics.add("gyro_zero", self._gyro_check)
        self.start_reading()

    def handle_bytes(self, data: bytes, host_time: float) -> None:
        stamp = self.stamp(host_time)
        for frame in self.decoder.feed(data):
            reading = self.converter.convert(frame)
            if reading is None:
                continue
            self.message_seen()
            if reading.gyro is not None:
                self._imu(stamp, reading)
            if reading.roll is not None:
                msg = Inclination(roll=reading.roll, pitch=reading.pitch, roll_variance=self.incl_var,
                                  pitch_variance=self.incl_var)
                msg.header.stamp, msg.header.frame_id = stamp, self.incl_frame
                self.incl_pub.publish(msg)
                self.published += 1
            if reading.mag is not None:
                msg = MagneticField()
                msg.header.stamp, msg.header.frame_id = stamp, self.mag_frame
                msg.magnetic_field.x, msg.magnetic_field.y, msg.magnetic_field.z = (float(v) for v in reading.mag)
                msg.magnetic_field_covariance = [self.mag_var, 0.0, 0.0, 0.0, self.mag_var, 0.0, 0.0, 0.0, self.mag_var]
                self.mag_pub.publish(msg)
                self.published += 1

    def _imu(self, stamp, reading):
        msg = Imu()
        msg.header.stamp, msg.header.frame_id = stamp, self.imu_frame
        msg.orientation.w = 0.0
        msg.orientation_covariance[0] = -1.0
        msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = (float(v) for v in reading.gyro)
        msg.angular_velocity_covariance = [self.gyro_var, 0.0, 0.0, 0.0, self.gyro_var, 0.0, 0.0, 0.0, self.gyro_var]
        if reading.accel is not None:
            a = msg.linear_acceleration
            a.x, a.y, a.z = (float(v) for v in reading.accel)
            msg.linear_acceleration_covariance = [self.accel_var, 0.0, 0.0, 0.0, self.accel_var, 0.0, 0.0, 0.0,
                                                  self.accel_var]
        else:
            msg.linear_acceleration_covariance[0] = -1.0
        self.imu_pub.publish(msg)
        self.published += 1

    def _calibrate(self, request, response):
        response.success = self.converter.request_calibration()
        response.message = (f"measuring V_static over the next {self.converter.calibrator.samples} samples; "
                            "keep the vehicle still" if response.success else "no gyro channels configured")
        return response

    def _check(self):
        c = self.decoder.counters
        counters = {k: getattr(c, k) for k in ("frames", "crc_failures", "parse_errors", "dropped_frames",
                                               "noise_bytes")}
        counters["rejected"] = self.converter.rejected
        return self.stream_check(counters, {"frames": c.frames}, c.crc_failures + c.parse_errors
                                 + self.converter.rejected, {"last_problem": c.last_problem
                                                             or self.converter.last_problem})

    def _gyro_check(self):
        cal, v = self.converter.calibrator, self.converter.v_static
        values = {"v_static": "unknown" if v is None else " ".join(f"{x:.4f}" for x in v),
                  "calibrating": cal.collecting, "rejected_windows": cal.rejected_windows,
                  "last_window_std": cal.last_std}
        if not self.converter.has_gyro:
            return OK, "no gyro channels", values
        if v is None:
            return WARN, "V_static not measured yet: keep the vehicle still (no /imu/data_raw until then)", values
        if cal.collecting:
            return WARN, "re-measuring V_static: keep the vehicle still", values
        return OK, "V_static measured", values


main = main_for(AdcSensorNode)
