"""Python message classes from ROS 2 type names (rosidl_runtime_py is not on PyPI)."""
import importlib


def message_class(msgtype):
    """'sensor_msgs/msg/Imu' -> sensor_msgs.msg.Imu; ImportError/AttributeError when not installed."""
    package, kind, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)
