"""Random scenarios for `agnav bench campaign`: everything a tractor meets, drawn from RANGES per seed.

draw(seed) -> (Scenario, params): the same seed gives the same scenario; `params` lists what was drawn (JSON-ready).
Sensor sets: the thesis package ("thesis": vibratory gyros + D5R-class inclinometers, no accelerometer) or a MEMS
IMU ("mems": gyro + accelerometer, optionally a magnetometer with hard/soft iron and passing disturbances);
receivers RTK (fixed with float episodes) or DGPS (wandering 2-10 cm); /gnss/vel present or not; optional wheel
speed with slip. Surfaces: flat, cross slope (with crab), tilled field, the thesis' rough road with sway.
"""
import math
from dataclasses import replace

import numpy as np

from .route import DriverParams, rounded_loop, straight
from .scenarios import BRAIN, D5R, MEMS_ACCEL, MEMS_GYRO, MX240, SAPPORO, SMALL_TRACTOR, Scenario, env05f, \
    field_passes
from .sensors.fluxgate import FluxgateParams
from .sensors.gnss import FIX_DGPS, FIX_RTK_FIXED, GnssParams
from .sensors.magnetic_field import DisturbanceParams
from .sensors.wheel import WheelParams
from .sway import SwayParams
from .terrain import TerrainParams

RANGES = {  # uniform draws (min, max); choices are in draw()
    "speed_mps": (0.5, 5.0),
    "rough_road_speed_mps": (0.5, 1.2),
    "drive_s": (50.0, 100.0),            # s in motion; with standstills and braking a run is ≈60-120 s
    "start_standstill_s": (5.0, 15.0),
    "slope_deg": (2.0, 10.0),
    "crab_gain": (0.1, 0.4),             # side slip (rad) per rad of cross slope
    "tilled_rough_deg": (0.5, 1.5),
    "sway_rms_deg": (0.0, 0.8),          # tyre/suspension sway off the rough road
    "incl_tau_s": (0.3, 1.5),
    "incl_zero_deg": (0.05, 0.3),        # inclinometer zero error bound (uniform ±)
    "mount_tilt_deg": (0.0, 0.2),        # IMU roll/pitch misalignment bound beyond /tf_static
    "mount_yaw_deg": (0.0, 1.0),
    "latency_s": (0.0, 0.2),
    "latency_jitter_s": (0.0, 0.05),
    "dgps_wander_m": (0.02, 0.10),
    "rtk_wander_m": (0.005, 0.015),
    "float_sigma_m": (0.1, 0.3),
    "float_s": (5.0, 20.0),
    "outage_s": (5.0, 30.0),
    "antenna_height_m": (1.5, 3.3),
    "antenna_x_m": (-2.0, 0.5),
    "imu_height_m": (0.8, 2.0),
    "wheel_slip": (0.0, 0.15),
    "hard_iron_mg": (50.0, 300.0),
    "soft_iron": (0.02, 0.10),
    "passing_mg": (50.0, 300.0),
}
PROBABILITY = {"mems": 0.5, "rtk": 0.5, "gnss_vel": 0.7, "outage": 0.3, "float": 0.4, "wheel": 0.3, "mag": 0.5}
SURFACES = ("flat", "slope", "tilled", "rough_road")
ROUTES = ("straight", "loop", "passes")
MAX_LATERAL_MPS2 = 1.5  # turn radius >= v^2 / this


def _u(rng, key):
    return float(rng.uniform(*RANGES[key]))


def _route(rng, kind, speed, drive_s):
    """(polyline, description) of about speed·drive_s metres."""
    length = speed * drive_s
    radius = max(4.0, speed ** 2 / MAX_LATERAL_MPS2)
    if kind == "straight":
        return straight(length, yaw=float(rng.uniform(-math.pi, math.pi))), f"straight {length:.0f} m"
    if kind == "loop":
        width = max(2 * radius + 2.0, 0.2 * length)
        long = max(2 * radius + 2.0, (length + (8 - 2 * math.pi) * radius) / 2 - width)
        return rounded_loop(long, width, radius, overlap_m=5.0), f"loop {long:.0f}×{width:.0f} m, r {radius:.0f} m"
    spacing = 2 * radius
    pass_len = float(rng.uniform(20.0, 150.0))
    passes = max(2, int(round(length / (pass_len + math.pi * radius))))
    pass_len = max(10.0, length / passes - math.pi * radius)
    return field_passes(pass_len, spacing, passes), f"{passes} passes of {pass_len:.0f} m, U-turns {spacing:.0f} m"


def _terrain(rng, surface, p):
    sway = SwayParams(*(2 * [_u(rng, "sway_rms_deg")]))
    if surface == "flat":
        return TerrainParams(rough_rms_deg=0.1, rough_wavelength_m=(1.0, 4.0)), sway, 0.0
    if surface == "slope":
        p["slope_deg"] = _u(rng, "slope_deg")
        return (TerrainParams(rough_rms_deg=0.3, rough_wavelength_m=(2.0, 8.0), slope_deg=p["slope_deg"],
                              slope_axis_yaw=float(rng.uniform(-math.pi, math.pi)), slope_ramp_m=(-1e4, -1e4 + 1.0)),
                sway, _u(rng, "crab_gain"))
    if surface == "tilled":
        return TerrainParams(rough_rms_deg=_u(rng, "tilled_rough_deg"), rough_wavelength_m=(3.0, 15.0)), sway, 0.0
    # the thesis' rough road (scenario rough_road_sway): 1.8-2 deg r.m.s. sway in 0.3-2 Hz
    return (TerrainParams(rough_rms_deg=0.8, rough_wavelength_m=(1.5, 4.0)),
            SwayParams(roll_rms_deg=2.0, pitch_rms_deg=1.8, band_hz=(0.3, 2.0), pitch_band_hz=(0.3, 0.8)), 0.0)


def _gnss(rng, rtk, drive_s, start_s, p):
    latency, jitter = _u(rng, "latency_s"), _u(rng, "latency_jitter_s")
    outages, floats = (), ()
    if rng.uniform() < PROBABILITY["outage"]:
        dur = _u(rng, "outage_s")
        t0 = start_s + float(rng.uniform(0.3, 0.8)) * drive_s
        outages = ((t0, t0 + dur),)
    if rtk:
        wander, rate = _u(rng, "rtk_wander_m"), float(rng.choice([5.0, 10.0]))
        if rng.uniform() < PROBABILITY["float"]:
            dur = _u(rng, "float_s")
            t0 = start_s + float(rng.uniform(0.1, 0.7)) * drive_s
            floats = ((t0, t0 + dur),)
        params = GnssParams(model="RTK", rate_hz=rate, bias_sigma_m=wander, bias_tau_s=60.0, white_sigma_m=0.008,
                            latency_s=latency, vel_noise_mps=0.02, fix_type=FIX_RTK_FIXED, satellites=16, hdop=0.7,
                            correction_age_s=1.0, latency_jitter_s=jitter, outages=outages, float_episodes=floats,
                            float_sigma_m=_u(rng, "float_sigma_m") if floats else 0.15)
    else:
        wander, rate = _u(rng, "dgps_wander_m"), float(rng.choice([1.0, 2.0, 5.0]))
        params = GnssParams(model="DGPS", rate_hz=rate, bias_sigma_m=wander, bias_tau_s=float(rng.uniform(60, 300)),
                            white_sigma_m=0.015, latency_s=latency, vel_noise_mps=0.05, fix_type=FIX_DGPS,
                            satellites=10, hdop=0.9, correction_age_s=float(rng.uniform(2.0, 10.0)),
                            latency_jitter_s=jitter, outages=outages)
    p.update(receiver="RTK" if rtk else "DGPS", gnss_rate_hz=rate, wander_m=round(wander, 4),
             latency_s=round(latency, 3), jitter_s=round(jitter, 3), outages=[list(map(float, o)) for o in outages],
             float_episodes=[list(map(float, f)) for f in floats])
    return params


def draw(seed, drive_s=None):
    """(Scenario, drawn parameters) of campaign seed `seed`; drive_s fixes the time in motion (s)."""
    rng = np.random.default_rng([15, int(seed)])
    deg = math.radians
    sensor_set = "mems" if rng.uniform() < PROBABILITY["mems"] else "thesis"
    rtk = bool(rng.uniform() < PROBABILITY["rtk"])
    gnss_vel = bool(rng.uniform() < PROBABILITY["gnss_vel"])
    surface, route_kind = str(rng.choice(SURFACES)), str(rng.choice(ROUTES))
    speed = _u(rng, "rough_road_speed_mps" if surface == "rough_road" else "speed_mps")
    drive = float(drive_s) if drive_s else _u(rng, "drive_s")
    start = _u(rng, "start_standstill_s")
    p = dict(seed=int(seed), sensor_set=sensor_set, gnss_vel=gnss_vel, surface=surface, speed_mps=round(speed, 2))
    route, p["route"] = _route(rng, route_kind, speed, drive)
    terrain, sway, crab = _terrain(rng, surface, p)
    p.update(sway_rms_deg=[round(sway.roll_rms_deg, 2), round(sway.pitch_rms_deg, 2)], crab_gain=round(crab, 2))
    gnss = _gnss(rng, rtk, drive, start, p)
    imu_xyz = (float(rng.uniform(0.0, 1.5)), 0.0, _u(rng, "imu_height_m"))
    ant_xyz = (_u(rng, "antenna_x_m"), float(rng.uniform(-0.3, 0.3)), _u(rng, "antenna_height_m"))
    imu_yaw = float(rng.choice([0.0, math.pi / 2, -math.pi / 2, math.pi])) if sensor_set == "mems" else 0.0
    tilt, yaw_err = _u(rng, "mount_tilt_deg"), _u(rng, "mount_yaw_deg")
    mount_err = (deg(rng.uniform(-tilt, tilt)), deg(rng.uniform(-tilt, tilt)), deg(rng.uniform(-yaw_err, yaw_err)))
    zero = (0.0, 0.0, 0.0)
    mounts = {"imu_link": (imu_xyz, (0.0, 0.0, imu_yaw)), "gnss_link": (ant_xyz, zero),
              "mag_link": (imu_xyz, (0.0, 0.0, imu_yaw)), "inclinometer_link": (imu_xyz, zero)}
    p.update(imu_xyz=[round(v, 2) for v in imu_xyz], antenna_xyz=[round(v, 2) for v in ant_xyz],
             imu_yaw_deg=round(math.degrees(imu_yaw)), mount_error_deg=[round(math.degrees(v), 3) for v in mount_err])
    kw = {}
    if sensor_set == "thesis":
        tau, z = _u(rng, "incl_tau_s"), _u(rng, "incl_zero_deg")
        kw.update(gyro=env05f(tuple(rng.uniform(-0.2, 0.2, 3))), accel=None,
                  incl=replace(D5R, tau_s=tau, offset_deg=z))
        p.update(incl_tau_s=round(tau, 2), incl_zero_bound_deg=round(z, 2))
    else:
        kw.update(gyro=MEMS_GYRO, accel=MEMS_ACCEL, incl=None)
        if rng.uniform() < PROBABILITY["mag"]:
            events = tuple((start + float(rng.uniform(0, drive)), float(rng.uniform(2.0, 8.0)), _u(rng, "passing_mg"))
                           for _ in range(int(rng.integers(0, 3))))
            kw.update(mag=FluxgateParams(hard_iron_mg=_u(rng, "hard_iron_mg"), soft_iron=_u(rng, "soft_iron"),
                                         noise_mg=2.0, range_mg=2000.0),
                      magnetic=DisturbanceParams(base_deg=float(rng.uniform(0.2, 1.0)), peak_deg=1.0, passing=events),
                      mag_rate_hz=50.0)
            p.update(mag=dict(hard_iron_mg=round(kw["mag"].hard_iron_mg), soft_iron=round(kw["mag"].soft_iron, 3),
                              passing=len(events)))
    if rng.uniform() < PROBABILITY["wheel"]:
        kw["wheel"] = WheelParams(slip_mean=_u(rng, "wheel_slip"))
        p["wheel_slip"] = round(kw["wheel"].slip_mean, 3)
    sc = Scenario(f"campaign_{seed}", f"campaign seed {seed}: {sensor_set}, {p['receiver']}, {surface}, {p['route']} "
                  f"at {speed:.1f} m/s", route=route,
                  driver=DriverParams(speed_mps=speed, accel_mps2=min(0.5, 0.1 * speed + 0.2),
                                      start_standstill_s=start, end_standstill_s=3.0, lookahead_s=1.5),
                  vehicle=MX240 if speed > 3.0 else SMALL_TRACTOR, terrain=terrain, gnss=gnss, mounts=mounts,
                  datum=BRAIN if rng.uniform() < 0.5 else SAPPORO, sway=sway if sway.roll_rms_deg > 0 else None,
                  crab_gain=crab, mount_errors={"imu_link": mount_err, "mag_link": mount_err}, gnss_vel=gnss_vel,
                  **kw)
    return sc, p
