"""The IMU's yaw mount beyond /tf_static, an augmented EKF state (error_model.MOUNT_YAW, + right): the IMU samples are
turned by its estimate onto base_link's axes, and a correction of the estimate turns the body axes with it (the
accelerometers head the IMU, the lever arms and the NHC the vehicle; `constraints`, `measurements` carry its
columns)."""
import math

from . import quaternion
from .mechanization import _floats, mat3, rotation_rows


class YawMount:
    """The estimate (rad) and the turn it gives the samples."""

    def __init__(self, yaw=0.0):
        self.set(yaw)

    def set(self, yaw):
        self.yaw, self._c, self._s = yaw, math.cos(yaw), math.sin(yaw)

    def turn(self, gyro, accel):
        """A sample's rate and specific force (body FRD) on the estimated vehicle axes."""
        c, s = self._c, self._s
        if not s:
            return gyro, accel
        (g0, g1, g2), (a0, a1, a2) = _floats(gyro), _floats(accel)
        return (c * g0 - s * g1, s * g0 + c * g1, g2), (c * a0 - s * a1, s * a0 + c * a1, a2)

    def correct(self, state, dm):
        """Estimate minus dm (closed loop); the body axes of the INS state move with it: C_B^Cbar R_z(dm)."""
        if dm:
            state.q = quaternion.from_dcm(mat3(state.dcm_rows(), rotation_rows(0.0, 0.0, dm)))
            self.set(self.yaw - dm)
