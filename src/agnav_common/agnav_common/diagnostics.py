"""Minimal diagnostic updater (diagnostic_updater is not on PyPI): named checks published every
`diagnostic_updater.period` seconds (that package's parameter, default 1.0 s, read-only here)."""
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor

OK, WARN, ERROR, STALE = (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR,
                          DiagnosticStatus.STALE)


class Diagnostics:
    """Collects named checks of one node; each check returns (level, message, {key: value})."""

    PERIOD = "diagnostic_updater.period"

    def __init__(self, node, hardware_id, period=1.0):
        self._node = node
        self._hardware_id = hardware_id
        self._checks = []
        if not node.has_parameter(self.PERIOD):  # as diagnostic_updater: one parameter per node
            node.declare_parameter(self.PERIOD, float(period), ParameterDescriptor(
                description="s between /diagnostics messages of this node", read_only=True,
                floating_point_range=[FloatingPointRange(from_value=0.01, to_value=3600.0)]))
        self.period = node.get_parameter(self.PERIOD).value
        self._pub = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._timer = node.create_timer(self.period, self.publish)

    def add(self, name, check):
        """Register `check()` under `<node name>: <name>`."""
        self._checks.append((f"{self._node.get_name()}: {name}", check))

    def publish(self):
        """Run every check now and publish one DiagnosticArray."""
        array = DiagnosticArray()
        array.header.stamp = self._node.get_clock().now().to_msg()
        for name, check in self._checks:
            try:
                level, message, values = check()
            except Exception as exc:  # a broken check is itself a diagnostic, never a crash
                level, message, values = ERROR, f"check failed: {exc}", {}
            array.status.append(DiagnosticStatus(
                level=level, name=name, message=message, hardware_id=self._hardware_id,
                values=[KeyValue(key=str(k), value=str(v)) for k, v in values.items()]))
        self._pub.publish(array)
