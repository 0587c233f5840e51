"""SimRun (whole simulated run as numpy arrays) and simulate(): the offline entry point of SIM_CONTRACT.md."""
from dataclasses import dataclass, field

import numpy as np

from .messages import run_rows
from .simulator import TractorSimulator


@dataclass
class Truth:
    """base_link in map at the IMU rate: position (m), REP-103 attitude (rad), ENU velocity, FLU rates."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    yaw: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    vz: np.ndarray
    wx: np.ndarray
    wy: np.ndarray
    wz: np.ndarray
    speed: np.ndarray
    steer: np.ndarray


@dataclass
class ImuData:
    """Gyro (rad/s) and accelerometer (m/s^2, or None) in imu_link, FLU."""

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray | None


@dataclass
class InclData:
    """Raw inclinometer roll/pitch (rad, REP-103)."""

    t: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray


@dataclass
class MagData:
    """Fluxgate field (tesla) in mag_link."""

    t: np.ndarray
    field: np.ndarray


@dataclass
class GnssData:
    """Antenna fixes: epoch t, arrival time, geodetic position, ENU covariance, fix type, ENU velocity."""

    t: np.ndarray
    t_arrival: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    alt: np.ndarray
    cov: np.ndarray
    fix_type: np.ndarray
    vel: np.ndarray
    vel_cov: np.ndarray
    satellites: np.ndarray
    hdop: np.ndarray
    correction_age: np.ndarray
    enu: np.ndarray
    truth_enu: np.ndarray


@dataclass
class SimRun:
    """One simulated run (SIM_CONTRACT.md); extras carries the sensors' hidden error parameters for tests."""

    scenario: str
    seed: int
    datum: tuple
    mounts: dict
    truth: Truth
    imu: ImuData
    incl: InclData | None
    mag: MagData | None
    gnss: GnssData | None
    gyro_truth_bias: np.ndarray
    imu_rate_hz: float
    extras: dict = field(default_factory=dict)
    messages: list | None = None  # [(publish time s, topic, msg)] as `agnav sim` writes them to a bag (messages=True)


def _stack(samples, keys, cls, **fixed):
    if not samples:
        return None
    t = np.array([s[0] for s in samples])
    cols = {k: np.array([s[1][k] for s in samples]) for k in keys}
    return cls(t=t, **cols, **fixed)


def simulate(scenario="asphalt_loop", seed=0, messages=False, **overrides):
    """Run a scenario to the end with the built-in driver; deterministic per seed. -> SimRun (with the ROS messages
    of the run, in the order of its bag, when `messages`)."""
    sim = TractorSimulator(scenario, seed, **overrides)
    by_kind = {k: [] for k in ("truth", "imu", "incl", "mag", "gnss", "wheel")}

    def collect(kind, stamp, data):
        by_kind[kind].append((stamp, data))
    rows = run_rows(sim, collect)[1] if messages else None
    while not sim.done:
        for sample in sim.step():
            collect(*sample)
    sc = sim.scenario
    imu = by_kind["imu"]
    accel = np.array([d["accel"] for _, d in imu]) if sim.accel else None
    extras = dict(declination_deg=sim.magnetic.declination_deg, inclination_deg=sim.magnetic.inclination_deg,
                  earth_field_enu=sim.magnetic.b_earth, gyro_scale=sim.gyro.scale,
                  gyro_motion_bias=sim.gyro.motion_bias, description=sc.description)
    if sim.fluxgate:
        extras.update(mag_hard_iron=sim.fluxgate.hard_iron, mag_matrix=sim.fluxgate.matrix)
    if sim.incl:
        extras.update(incl_offset=sim.incl.offset, incl_variance=sim.incl.variance)
    if sim.accel:
        extras.update(accel_bias=sim.accel.bias)
    if sim.fluxgate:
        extras.update(mag_variance=sim.fluxgate.variance)
    return SimRun(
        scenario=sc.name, seed=seed, datum=tuple(sc.datum), mounts=dict(sc.mounts),
        truth=_stack(by_kind["truth"], [f for f in Truth.__dataclass_fields__ if f != "t"], Truth),
        imu=ImuData(t=np.array([s for s, _ in imu]), gyro=np.array([d["gyro"] for _, d in imu]), accel=accel),
        incl=_stack(by_kind["incl"], ["roll", "pitch"], InclData),
        mag=_stack(by_kind["mag"], ["field"], MagData),
        gnss=_stack(by_kind["gnss"], [f for f in GnssData.__dataclass_fields__ if f != "t"], GnssData),
        gyro_truth_bias=np.array([d["bias"] for _, d in imu]), imu_rate_hz=sc.imu_rate_hz, extras=extras,
        messages=rows)
