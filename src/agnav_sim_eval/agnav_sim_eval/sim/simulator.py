"""TractorSimulator: steps vehicle, terrain and every sensor of a scenario at the IMU rate (online or offline)."""
import math
from dataclasses import replace

import numpy as np

from agnav_common.frames import rotation_matrix
from agnav_common.geodesy import LocalTangentPlane

from .route import RouteDriver
from .scenarios import SCENARIOS, Scenario
from .sensors.accelerometer import Accelerometer
from .sensors.fluxgate import Fluxgate
from .sensors.gnss import GnssReceiver
from .sensors.gyro import Gyro
from .sensors.inclinometer import Inclinometer
from .sensors.lowpass import FirstOrderLag
from .sensors.magnetic_field import MagneticEnvironment
from .sensors.wheel import WheelSpeed
from .sway import Sway
from .terrain import Terrain, attitude_on_terrain
from .vehicle import BicycleModel, BicycleState

GRAVITY = 9.80665
_STREAMS = ("terrain", "driver", "gyro", "accel", "incl", "magnetic", "fluxgate", "gnss", "sway", "wheel")


def resolve(scenario, **overrides):
    """Scenario object from a name or Scenario, with dataclass field overrides."""
    sc = SCENARIOS[scenario] if isinstance(scenario, str) else scenario
    if not isinstance(sc, Scenario):
        raise TypeError(f"not a scenario: {scenario!r}")
    return replace(sc, **overrides) if overrides else sc


def euler_rates_to_body(roll, pitch, droll, dpitch, dyaw):
    """Body (FLU) angular rate from REP-103 Z-Y-X Euler-angle rates."""
    sr, cr, sp, cp = math.sin(roll), math.cos(roll), math.sin(pitch), math.cos(pitch)
    return np.array([droll - sp * dyaw, cr * dpitch + sr * cp * dyaw, -sr * dpitch + cr * cp * dyaw])


class _Mount:
    """Sensor mount: lever arm (m) and rotation sensor->base_link, plus the previous sensor velocity."""

    def __init__(self, xyz, rpy):
        self.r = np.asarray(xyz, dtype=float)
        self.rot = rotation_matrix(*rpy)
        self.prev_vel = None


class TractorSimulator:
    """Online simulation of one scenario; `step(steering_angle)` advances one IMU tick (1/imu_rate_hz s).

    steering_angle: front-wheel angle command (rad, + left); None lets the built-in route driver steer.
    Returns samples due this tick as (kind, stamp, data) with kind in truth/imu/incl/mag/gnss; GNSS samples are
    returned at the tick of their arrival (stamp = epoch, data["t_arrival"]).
    """

    def __init__(self, scenario="asphalt_loop", seed=0, **overrides):
        sc = self.scenario = resolve(scenario, **overrides)
        rng = dict(zip(_STREAMS, (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(len(_STREAMS)))))
        self.dt = 1.0 / sc.imu_rate_hz
        self.plane = LocalTangentPlane(*sc.datum)
        self.terrain = Terrain(sc.terrain, rng["terrain"])
        self.driver = RouteDriver(sc.route, sc.driver, sc.vehicle.wheelbase_m, rng["driver"])
        self.vehicle = BicycleModel(sc.vehicle, BicycleState(*sc.route[0], yaw=self.driver.initial_yaw))
        self.gyro = Gyro(sc.gyro, rng["gyro"])
        self.accel = Accelerometer(sc.accel, rng["accel"]) if sc.accel else None
        self.incl = Inclinometer(sc.incl, rng["incl"]) if sc.incl else None
        self.magnetic = MagneticEnvironment(sc.datum, sc.magnetic, rng["magnetic"])
        self.fluxgate = Fluxgate(sc.mag, rng["fluxgate"]) if sc.mag else None
        self.gnss = GnssReceiver(sc.gnss, rng["gnss"]) if sc.gnss else None
        self.sway = Sway(sc.sway, rng["sway"]) if sc.sway else None
        self.wheel = WheelSpeed(sc.wheel, rng["wheel"]) if sc.wheel else None
        self._crab = FirstOrderLag(sc.crab_tau_s)
        self.crab = 0.0
        zero = (0.0, 0.0, 0.0)  # true mount = nominal (/tf_static) + mount error
        self.mounts = {name: _Mount(xyz, np.add(rpy, sc.mount_errors.get(name, zero)))
                       for name, (xyz, rpy) in sc.mounts.items()}
        self.k = -1
        self.travelled = 0.0
        self._stopped_since = None
        self._end_at = None
        self._pending_gnss = []
        self._prev = None
        self._truth = None
        self.done = False

    @property
    def t(self):
        """Simulation time of the latest tick (s)."""
        return self.k * self.dt

    def truth_state(self):
        """Latest true state: dict with t, x, y, z, roll, pitch, yaw, vx, vy, vz (ENU), wx, wy, wz (FLU), speed, steer."""
        return self._truth

    def _due(self, rate_hz):
        """True on ticks where a sensor of rate_hz samples (epochs at multiples of 1/rate_hz)."""
        if rate_hz >= self.scenario.imu_rate_hz:
            return True
        return math.floor(self.t * rate_hz + 1e-9) != math.floor((self.t - self.dt) * rate_hz + 1e-9) or self.k == 0

    def _advance(self, steering_angle):
        st = self.vehicle.state
        cmd = steering_angle
        if cmd is None:
            cmd = self.driver.steering_command(st.x, st.y, st.yaw, st.speed, self.dt)
        v_cmd = self.driver.speed_command(self.t - self.dt, self.travelled)
        self.travelled += self.vehicle.step(self.dt, cmd, v_cmd, self.crab)

    def _kinematics(self):
        """Truth at the current tick; rates and vertical speed are backward differences over the last tick."""
        sc, st = self.scenario, self.vehicle.state
        z, roll, pitch = attitude_on_terrain(self.terrain, st.x, st.y, st.yaw, sc.vehicle.wheelbase_m,
                                             sc.vehicle.track_m)
        if sc.crab_gain:  # slides downhill: roll + (right side down) -> velocity right of the heading
            self.crab = float(self._crab.update(-sc.crab_gain * roll, self.dt)) * min(1.0, st.speed / 0.3)
        if self.sway is not None:
            d_roll, d_pitch = self.sway.angles(self.t, st.speed)
            roll, pitch = roll + d_roll, pitch + d_pitch
        if self._prev is None:
            w, vz = np.zeros(3), 0.0
        else:
            p = self._prev
            rates = [(roll - p["roll"]) / self.dt, (pitch - p["pitch"]) / self.dt,
                     math.remainder(st.yaw - p["yaw"], 2 * math.pi) / self.dt]
            w = euler_rates_to_body(0.5 * (roll + p["roll"]), 0.5 * (pitch + p["pitch"]), *rates)
            vz = (z - p["z"]) / self.dt
        return dict(t=self.t, x=st.x, y=st.y, z=z, roll=roll, pitch=pitch, yaw=st.yaw,
                    vx=st.speed * math.cos(st.yaw + self.crab), vy=st.speed * math.sin(st.yaw + self.crab), vz=vz,
                    wx=w[0], wy=w[1], wz=w[2], speed=st.speed, steer=st.steer)

    def _sensor_motion(self, mount, rot, vel, w):
        """(ENU position, ENU velocity, specific force in the sensor frame) of a mounted sensor."""
        pos_arm = rot @ mount.r
        r = mount.r
        v = vel + rot @ np.array([w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2], w[0] * r[1] - w[1] * r[0]])
        acc = np.zeros(3) if mount.prev_vel is None else (v - mount.prev_vel) / self.dt
        mount.prev_vel = v
        f_body = rot.T @ (acc + np.array([0.0, 0.0, GRAVITY]))
        return pos_arm, v, mount.rot.T @ f_body

    def step(self, steering_angle=None):
        """Advance one tick and return the samples due in it."""
        if self.done:
            return []
        self.k += 1
        if self.k > 0:
            self._advance(steering_angle)
        tr = self._truth = self._kinematics()
        self._prev = tr
        t, dt = self.t, self.dt
        rot = rotation_matrix(tr["roll"], tr["pitch"], tr["yaw"])
        pos = np.array([tr["x"], tr["y"], tr["z"]])
        vel = np.array([tr["vx"], tr["vy"], tr["vz"]])
        w = np.array([tr["wx"], tr["wy"], tr["wz"]])
        moving = tr["speed"] > 0.01
        out = [("truth", t, tr)]

        imu = self.mounts["imu_link"]
        _, _, f_imu = self._sensor_motion(imu, rot, vel, w)
        gyro = self.gyro.sample(t, dt, imu.rot.T @ w, moving)
        accel = self.accel.sample(dt, f_imu) if self.accel else None
        out.append(("imu", t, dict(gyro=gyro, accel=accel, bias=self.gyro.bias.copy())))

        if self.incl:
            inc = self.mounts["inclinometer_link"]
            _, _, f_inc = self._sensor_motion(inc, rot, vel, w)
            r_sensor = rot @ inc.rot
            roll, pitch, _ = _euler(r_sensor)
            angles = self.incl.sample(dt, roll, pitch, f_inc)
            out.append(("incl", t, dict(roll=angles[0], pitch=angles[1])))

        if self.fluxgate and self._due(self.scenario.mag_rate_hz):
            mag = self.mounts["mag_link"]
            p_mag = pos + rot @ mag.r
            field = self.fluxgate.sample(1.0 / self.scenario.mag_rate_hz, rot @ mag.rot,
                                         self.magnetic.field(p_mag[0], p_mag[1], t))
            out.append(("mag", t, dict(field=field)))

        if self.wheel and self._due(self.wheel.params.rate_hz):
            out.append(("wheel", t, dict(speed=self.wheel.sample(1.0 / self.wheel.params.rate_hz, tr["speed"]))))

        if self.gnss:
            ant = self.mounts["gnss_link"]
            arm, v_ant, _ = self._sensor_motion(ant, rot, vel, w)
            if self._due(self.gnss.params.rate_hz):
                enu, v_meas = self.gnss.sample(1.0 / self.gnss.params.rate_hz, pos + arm, v_ant, t)
            if self._due(self.gnss.params.rate_hz) and self.gnss.available(t):
                lat, lon, alt = self.plane.to_geodetic(*enu)
                fix_type, cov = self.gnss.status(t)
                self._pending_gnss.append((t, dict(
                    t_arrival=self.gnss.arrival(t), lat=float(lat), lon=float(lon), alt=float(alt),
                    enu=enu, cov=cov, vel=v_meas, vel_cov=self.gnss.velocity_cov,
                    fix_type=fix_type, satellites=self.gnss.params.satellites,
                    hdop=self.gnss.params.hdop, correction_age=self.gnss.params.correction_age_s,
                    truth_enu=pos + arm)))
            while self._pending_gnss and self._pending_gnss[0][1]["t_arrival"] <= t + 1e-9:
                epoch, data = self._pending_gnss.pop(0)
                out.append(("gnss", epoch, data))

        self._update_done(tr)
        return out

    def _update_done(self, tr):
        p = self.scenario.driver
        if self.travelled >= self.driver.length - 0.05 and tr["speed"] == 0.0:
            self._stopped_since = self._stopped_since if self._stopped_since is not None else self.t
            if self.t - self._stopped_since >= p.end_standstill_s:  # then deliver the epochs measured until now
                self._end_at = self._end_at if self._end_at is not None else self.t
                self.done = not any(epoch <= self._end_at for epoch, _ in self._pending_gnss)
        max_t = p.start_standstill_s + p.end_standstill_s + 3.0 * self.driver.length / p.speed_mps + 30.0
        self.done = self.done or self.t >= max_t


def _euler(r):
    """REP-103 (roll, pitch, yaw) of a rotation matrix."""
    return (math.atan2(r[2, 1], r[2, 2]), -math.asin(max(-1.0, min(1.0, r[2, 0]))), math.atan2(r[1, 0], r[0, 0]))
