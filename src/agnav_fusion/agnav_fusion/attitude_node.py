"""Attitude node (SPEC §6.2) for graphs without GNSS: /imu/data_raw + /inclinometer -> /imu/data
(orientation + covariance, bias-corrected rates); with GNSS, nav_sensor_module_node publishes /imu/data itself.
Runs the navigation sensor module's attitude filters (estimator `agnav`: lag/acceleration KF; `thesis`:
attitude LSM eq 5.1-5.11); yaw is the gyro-integrated (relative) heading with an unknown-size variance.
Same parameters as nav_sensor_module_node.
"""
from agnav_common.node_main import main_for
from agnav_common.qos import PUBLISHER_QOS, create_output
from sensor_msgs.msg import Imu

from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode, imu_message
from agnav_fusion.nav_sensor_module_node import parameter_entries as nav_parameter_entries

UNKNOWN_VARIANCE = 99999.0


class AttitudeNode(NavSensorModuleNode):
    uses_gnss = False  # yaw stays relative (gyro-integrated, large variance); the datum is the module node's

    def __init__(self, **kwargs):
        super().__init__("attitude_node", **kwargs)
        self.publish_tf = False
        self.imu_pub = create_output(self, Imu, "imu/data", PUBLISHER_QOS)

    def ready(self, state):
        """Attitude is published from the first sample (yaw relative, with its large variance)."""
        return True

    def publish(self, s):
        self.imu_pub.publish(imu_message(s, self.frames["base"], max_yaw_variance=UNKNOWN_VARIANCE))

    def mounts_ready(self):
        """The attitude needs only the IMU mount; a missing GNSS mount means a zero lever arm."""
        if self.pipeline.imu_rotation is None and self.tf.lookup(self.frames["base"], self.frames["imu"]) is not None \
                and self.tf.lookup(self.frames["base"], self.frames["gnss"]) is None:
            self.frames["gnss"] = self.frames["base"]
        return super().mounts_ready()


def parameter_entries():
    """[(name, default, description)]: the navigation node's parameters (tools/gen_params.py)."""
    return nav_parameter_entries(AttitudeNode.estimator)


main = main_for(AttitudeNode)
