"""Console-script entry point shared by every agnav node: spin one node until SIGINT/SIGTERM."""
import signal

import rclpy
from rclpy.experimental import EventsExecutor


def spin_nodes(nodes, executor, stop):
    """Spin `nodes` on `executor` until `stop()` is true; timeouts keep EventsExecutor responsive."""
    for node in nodes:
        executor.add_node(node)
    while rclpy.ok() and not stop():
        executor.spin_once(timeout_sec=0.1)


def main_for(node_class):
    """Return a `main(args=None)` that runs `node_class` alone (parameters from --ros-args).

    The node runs until SIGINT/SIGTERM, or until it sets `finished` (e.g. a bag player at the end).
    `main.node_class` lets the graph runner start the same node in its own process.
    """

    def main(args=None):
        rclpy.init(args=args)
        stopping = []
        signal.signal(signal.SIGTERM, lambda *_: stopping.append(True))
        node = None
        try:
            node = node_class()
            spin_nodes([node], EventsExecutor(), lambda: bool(stopping) or getattr(node, "finished", False))
        except KeyboardInterrupt:
            pass
        finally:
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown()
        return 0

    main.node_class = node_class
    return main
