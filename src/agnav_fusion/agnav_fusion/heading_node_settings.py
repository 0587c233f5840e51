"""heading_node's parameters (agnav_common.parameters: declared once, described, read-only): the node's own
settings and those of the estimators, gate and ALE under their historical names and units (degrees where the
estimators use radians); every default comes from the estimators' dataclasses or is defined here once."""
import math
from dataclasses import dataclass, field

from agnav_common.input_guard import StreamClockSettings
from agnav_common.parameters import SIGNED
from agnav_common.variance_weighted_average import VwaSettings

from agnav_fusion.adaptive_line_enhancer import AleSettings
from agnav_fusion.gds_heading import CircleCalibration
from agnav_fusion.geomagnetic_model import DisturbanceSettings
from agnav_fusion.heading_estimators import EstimatorSettings
from agnav_fusion.heading_gate import GateSettings, GyroErrorSettings

ALE_INTERNAL = ("ale.normalized", "ale.eps")  # fixed ALE settings, no parameters
_EST, _GATE, _GYRO, _DIST = EstimatorSettings(), GateSettings(), GyroErrorSettings(), DisturbanceSettings()


def _deg(rad):
    """Degrees of a radian default, as the parameter shows it (0.4, not 0.39999999999999997)."""
    return round(math.degrees(rad), 9)


@dataclass
class MagParams:
    center: list = field(default_factory=lambda: CircleCalibration().center.tolist(), metadata=SIGNED)  # T, hard
    # iron centre (a, b) of the geomagnetic circle in base_link thesis axes (x right, y forward, z up), from a level
    # 360 deg turn with agnav_fusion.gds_heading.fit_ellipse
    soft_iron: list = field(default_factory=lambda: CircleCalibration().soft_iron.ravel().tolist())  # soft-iron
    # matrix W row by row (2x2; identity: circle only)
    z_offset: float = field(default=CircleCalibration.z_offset, metadata=SIGNED)  # T, vertical field offset


@dataclass
class DisturbanceParams:
    intensity_tolerance: float = _DIST.intensity_tolerance  # relative |F| error off the WMM value that flags the GDS
    inclination_tolerance_deg: float = _deg(_DIST.inclination_tolerance)  # deg of field inclination off the WMM
    innovation_k_sigma: float = _GATE.k_sigma      # GDS-minus-gyro innovation that flags a sample, in sigma
    reference_window: float = _GATE.reference_window  # s of clean GDS-gyro offsets forming the reference
    recover_time: float = _GATE.recover_time       # s of consistent samples before the GDS is fused again
    offset_sigma_floor_deg: float = _deg(_GATE.offset_sigma_floor)  # deg, lower bound of the offset spread


@dataclass
class GyroParams:  # yaw gyro errors a gyro-only heading accumulates while the GDS is disturbed (1 sigma)
    bias_sigma_deg_s: float = _deg(_GYRO.bias)       # deg/s of bias the estimator does not remove (VWA/KF: all)
    arw_deg_sqrt_s: float = _deg(_GYRO.arw)          # deg/sqrt(s), angle random walk
    bias_walk_deg_s_sqrt_s: float = _deg(_GYRO.bias_walk)  # deg/s/sqrt(s), rate random walk


@dataclass
class VwaParams(VwaSettings):
    window: float = _EST.vwa.window      # s, T of the variable-target VWA (Table 2.5; estimator vwa)
    interval: float = _EST.vwa.interval  # s, ΔT: target update interval


@dataclass
class LsmParams:
    window: float = _EST.lsm_window_s          # s, M of the drift LSM (3.18) as time (estimator gds_gyro_lsm)
    vwa_window: float = _EST.lsm_vwa.window    # s, T of the LSM's delayed VWA
    vwa_interval: float = _EST.lsm_vwa.interval  # s, ΔT of the LSM's delayed VWA


@dataclass
class KfDriftParams:
    drift_noise: float = _EST.kf.drift_noise  # 1/s, random walk of the KF's gyro drift state (thesis: 0; long runs)


@dataclass
class GdsParams:
    systematic_sigma_deg: float = _deg(_EST.gds_systematic_sigma)  # deg, GDS heading error no averaging removes
    # (WMM declination 0.3-0.4 deg rms, calibration residual), added to the GDS estimators' variance


@dataclass
class EventWindowParams:
    window: float = 10.0  # s of recent rejected inputs and flagged GDS samples that /diagnostics counts


@dataclass
class HeadingNodeSettings:
    estimator: str = _EST.estimator   # gds_kf (SPEC 3.5) | vwa (3.6) | gds_gyro_lsm (4.5-4.7) | gnss_gyro_lsm (5.1-5.2)
    base_frame: str = "base_link"     # frame of /heading/imu; sensor rotations come from TF to it
    tilt_source: str = "imu_data"     # imu_data (/imu/data) | inclinometer (/inclinometer, ALE-denoised) | none
    mag: MagParams = field(default_factory=MagParams)
    ale: AleSettings = field(default_factory=AleSettings)   # inclinometer denoising (tilt_source inclinometer)
    inclinometer_rate: float = 50.0   # Hz of /inclinometer (converts the ALE delay into s)
    gds_delay: float = field(default=-1.0, metadata=SIGNED)  # s of GDS heading latency; < 0: the ALE's delay
    declination_site: list = field(default_factory=lambda: [0.0], metadata=SIGNED)  # [lat deg, lon deg, alt m]
    # where the WMM is evaluated until the first /gnss/fix; not 3 values: no GDS heading before a fix
    wmm_fallback_year: float = 0.0    # year, date for stamps outside the WMM span (0: today)
    disturbance: DisturbanceParams = field(default_factory=DisturbanceParams)
    gyro: GyroParams = field(default_factory=GyroParams)
    kf: KfDriftParams = field(default_factory=KfDriftParams)
    vwa: VwaParams = field(default_factory=VwaParams)
    lsm: LsmParams = field(default_factory=LsmParams)
    imu_rate: float = _EST.imu_rate_hz   # Hz of /imu/data_raw (LSM window and delay in samples)
    nominal_speed: float = _EST.nominal_speed  # m/s, KF distance step when no GNSS speed is known (SPEC 3.4)
    gds: GdsParams = field(default_factory=GdsParams)
    stale_timeout: float = 1.0           # s without a needed input -> ERROR on /diagnostics
    stamp_max_jump: float = StreamClockSettings.max_jump  # s, a larger stamp step is held until confirmed
    diagnostics: EventWindowParams = field(default_factory=EventWindowParams)
