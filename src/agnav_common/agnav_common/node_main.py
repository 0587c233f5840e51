"""Console-script entry point shared by every agnav node: spin one node until SIGINT/SIGTERM.

Also the helpers the graph runner shares with it: stop flags set by signals (rc 0, no traceback on Ctrl-C),
the check that every parameter given to a node is one it declares, and one-line error messages.
"""
import difflib
import os
import signal
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.signals import SignalHandlerOptions

PARENT_ENV = "AGNAV_PARENT_PID"  # set by `agnav run --processes`: a child stops when that runner is gone


class ParameterNameError(ValueError):
    """A parameter given to a node that the node does not declare (a misspelling would be ignored silently)."""


def init_without_signal_handlers(args=None):
    """rclpy.init without rclpy's SIGINT handler (it shuts the context down under the executor, which then
    raises ExternalShutdownException); stop_on_signals() lets the spin loop end normally instead."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)


def stop_on_signals():
    """A list that receives the signal's name on SIGINT/SIGTERM (true once the process should stop)."""
    stopping = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, _: stopping.append(signal.Signals(signum).name))
    return stopping


def check_parameter_names(node, names):
    """Raise ParameterNameError for the first of `names` that `node` has not declared, with the closest ones."""
    declared = None
    for name in names:
        if node.has_parameter(name):
            continue
        declared = declared or node.list_parameters([], 0).names
        close = difflib.get_close_matches(name, declared, n=3, cutoff=0.0)
        raise ParameterNameError(f"node '{node.get_name()}': unknown parameter '{name}'; closest declared: "
                                 f"{', '.join(close) or 'none'}")


def one_line(exc):
    """An exception as one line of text (rclpy messages may span lines)."""
    return " ".join(str(exc).split()) or type(exc).__name__


def parent_gone():
    """True when the runner that started this process (PARENT_ENV) has died (e.g. SIGKILL)."""
    pid = os.environ.get(PARENT_ENV)
    return bool(pid) and os.getppid() != int(pid)


def spin_nodes(nodes, executor, stop):
    """Spin `nodes` on `executor` until `stop()` is true; timeouts keep EventsExecutor responsive."""
    for node in nodes:
        executor.add_node(node)
    try:
        while rclpy.ok() and not stop():
            executor.spin_once(timeout_sec=0.1)
    except ExternalShutdownException:
        pass  # the context was shut down from outside: a normal stop


def node_label(node_class, args):
    """The node's name for messages before it exists: `-r __node:=NAME` of the arguments, else the script."""
    args = sys.argv if args is None else args
    for arg in args:
        if arg.startswith("__node:="):
            return arg.split(":=", 1)[1]
    return os.path.basename(args[0]) if args else node_class.__name__


def main_for(node_class):
    """Return a `main(args=None)` that runs `node_class` alone (parameters from --ros-args).

    The node runs until SIGINT/SIGTERM (exit 0), or until it sets `finished` (e.g. a bag player at the end).
    A node that cannot be built (bad or unknown parameter) is one line on stderr and exit status 2.
    `main.node_class` lets the graph runner start the same node in its own process.
    """

    def main(args=None):
        node = None
        try:
            try:
                init_without_signal_handlers(args)  # parses --ros-args (-p, --params-file)
                stopping = stop_on_signals()
                node = node_class()
                # every parameter given (--params-file, -p) must be declared: a misspelling is an error
                check_parameter_names(node, list(node._parameter_overrides))
            except Exception as exc:  # noqa: BLE001  (reported as one line, not a traceback)
                label = node.get_name() if node is not None else node_label(node_class, args)
                msg = one_line(exc) if isinstance(exc, ParameterNameError) else f"node '{label}': {one_line(exc)}"
                print(f"{os.path.basename(sys.argv[0])}: error: {msg}", file=sys.stderr)
                return 2
            spin_nodes([node], EventsExecutor(),
                       lambda: bool(stopping) or getattr(node, "finished", False) or parent_gone())
        finally:
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown()
        return 0

    main.node_class = node_class
    return main
