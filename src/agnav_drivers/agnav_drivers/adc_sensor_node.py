"""Analog sensor ADC driver node: microcontroller frames over serial -> /imu/data_raw (vibratory
gyros, accelerometers if wired), /inclinometer, /imu/mag, /diagnostics; service
~/calibrate_gyro (std_srvs/Trigger) re-measures V_static at standstill. Conversions live in adc.py."""
from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field

from sensor_msgs.msg import Imu, MagneticField
from std_srvs.srv import Trigger

from agnav_common.diagnostics import OK, WARN
from agnav_common.node_main import main_for
from agnav_common.qos import PUBLISHER_QOS, create_output
from agnav_msgs.msg import Inclination

from .adc import AdcConverter, AdcDecoder, AdcSettings
from .stream_driver import StreamDriverNode, StreamSettings, stream_parameters

PARAMS_DOC = """Analog sensor box: microcontroller ADC -> adc_sensor_node (frame format in agnav_drivers/adc.py and
docs/drivers/README.md). Defaults: thesis Ch. V attitude package (3 x Murata ENV-05F-03 gyros, 2 x Omron D5R-L02-15
inclinometers) plus a Watson FGM-200A fluxgate GDS, 16-bit ADC, 5 V reference."""


@dataclass
class AdcNodeSettings(AdcSettings, StreamSettings):
    baud: int = 115200          # bit/s of the serial port
    stale_timeout: float = 0.5  # s without a valid frame -> WARN on /diagnostics
    stamp_source: str = "host"  # host receive time of the frame (the only source: frames carry no absolute time)
    frame_mode: str = inspect.signature(AdcDecoder).parameters["mode"].default  # binary (sync + length + CRC-16)
    # or csv (seq,t_us,code0,...)
    imu_frame_id: str = "imu_link"                    # frame of /imu/data_raw (gyros, accelerometers)
    inclinometer_frame_id: str = "inclinometer_link"  # frame of /inclinometer
    mag_frame_id: str = "mag_link"                    # frame of /imu/mag (fluxgate GDS)
    bits: int = AdcSettings.bits  # ADC resolution: volts = code * vref / 2^bits
    channels: list = field(default_factory=lambda: AdcSettings().channels)  # role of each ADC channel in frame
    # order, "" = unused: gyro_x/y/z, accel_x/y/z, incl_roll, incl_pitch, mag_x/y/z (sensor axes; mounts from TF)
    gyro_scale: tuple = AdcSettings.gyro_scale  # (deg/s)/V, K of the vibratory gyro, SPEC eq 3.8: omega =
    # K (V_out - V_static); ENV-05F-03 25 mV/(deg/s) -> 40, ENV-05D-52 22.2 mV/(deg/s) -> 45; a negative K flips an axis
    static_samples: int = AdcSettings.static_samples  # V_static = mean of this many samples at standstill (thesis:
    # 1000), on start and on ~/calibrate_gyro (std_srvs/Trigger); no /imu/data_raw before the first
    incl_zero: tuple = AdcSettings.incl_zero  # V, V0 of angle = (V - V0) / sensitivity (D5R: 2.5 V at 0 deg)
    incl_sign: tuple = AdcSettings.incl_sign  # thesis convention (pitch nose up) -> REP-103 (nose down)
    mag_zero: tuple = AdcSettings.mag_zero    # V at zero field (FGM-200A: 0 V at zero field, +-4 V, level-shifted)
    mag_scale: tuple = AdcSettings.mag_scale  # mG/V (FGM-200A 250 mG/V) -> tesla on /imu/mag (1 mG = 1e-7 T)
    accel_zero: tuple = AdcSettings.accel_zero  # V, optional accelerometers: a = (V - zero) * scale
    gyro_noise: float = 0.4     # deg/s rms on /imu/data_raw (ENV-05F-03 < 10 mV rms)
    accel_noise: float = 0.05   # m/s^2 rms
    incl_noise: float = 0.5     # deg rms on /inclinometer (thesis: 0.46-0.88 deg on asphalt/grass)
    mag_noise: float = 1.25     # mG rms on /imu/mag (5 mV ripple)


def parameter_entries():
    return stream_parameters(AdcNodeSettings())


class AdcSensorNode(StreamDriverNode):
    def __init__(self, **kwargs):
        super().__init__("adc_sensor", "adc_sensor", AdcNodeSettings(), **kwargs)
        s = self.settings
        self.converter = AdcConverter(s)
        self.decoder = AdcDecoder(s.frame_mode)
        self.imu_frame, self.incl_frame, self.mag_frame = s.imu_frame_id, s.inclinometer_frame_id, s.mag_frame_id
        self.gyro_var = math.radians(s.gyro_noise) ** 2        # (deg/s rms)^2 -> (rad/s)^2
        self.accel_var = s.accel_noise ** 2                    # (m/s^2)^2
        self.incl_var = math.radians(s.incl_noise) ** 2        # deg rms -> rad^2
        self.mag_var = (s.mag_noise * 1e-7) ** 2               # mG rms -> T^2
        self.imu_pub = create_output(self, Imu, "imu/data_raw", PUBLISHER_QOS)
        self.incl_pub = create_output(self, Inclination, "inclinometer", PUBLISHER_QOS)
        self.mag_pub = create_output(self, MagneticField, "imu/mag", PUBLISHER_QOS)
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
