"""In-process message bus: deterministic replay of a graph whose nodes all live in this process.

While a LocalBus is installed, every rclpy Node of the process creates its publishers and subscriptions on the bus
instead of DDS (Node methods are patched; graph queries — count_publishers, get_topic_names_and_types, ... — see
the bus). publish() calls the matching subscriptions' callbacks synchronously, depth-first, in the order the
subscriptions were created: when it returns, every node the message reached has handled it, and everything
those callbacks published in turn. With one source publishing in log-time order this is a discrete-event
simulation of the graph: same input, same output, bit for bit, on any machine load.

Sim time: a message on /clock advances the bus time. Timers on a clock that follows /clock (use_sim_time) fire
when due, in due-time order, each with every node clock at its due time; the node clocks read the bus time (the
nodes' TimeSources are served directly rather than through their /clock subscriptions: `now()` of their clocks
returns the bus time, and their rcl clocks, which the timers read, are set only when a timer is due or re-armed,
not at every bag stamp). Other timers (steady clock, wall time) and services are left to an executor.

Matching is by resolved topic name and message type (a subscription of another type is not connected, as in
DDS). Messages published as objects are shared, not copied, by the subscriptions (as rclcpp's intra-process
const subscriptions): callbacks must not modify what they receive. A message published as serialized bytes is
deserialized once per subscription; raw subscriptions get the bytes (a published object is serialized once, with
zeroed padding as on DDS: agnav_common.bagio.cdr).
Transient-local publishers keep their last message for transient-local subscriptions created later; those get it
at the next publish, /clock or flush(), never inside create_subscription. publish_dds=True also publishes every
message on DDS for a live viewer; bus subscriptions never take anything from DDS, so nothing arrives twice.
"""
from functools import partial
from types import SimpleNamespace

from rclpy.clock import ROSClock
from rclpy.clock_type import ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.time import Time
from rclpy.time_source import CLOCK_TOPIC, TimeSource

from agnav_common.bagio import cdr, from_cdr, type_name

_installed = None  # the LocalBus installed in this process, if any
_PATCHED = ("create_publisher", "create_subscription", "create_timer", "destroy_publisher", "destroy_subscription",
            "count_publishers", "count_subscribers", "get_topic_names_and_types", "get_publishers_info_by_topic")


def current():
    """The installed LocalBus, or None (nodes then talk over DDS)."""
    return _installed


def on_new_topic(listener):
    """Call `listener()` whenever a publisher on a new topic appears on the installed bus (no-op without one)."""
    if _installed is not None:
        _installed.topic_listeners.append(listener)


def _qos(qos_profile):
    return QoSProfile(depth=qos_profile) if isinstance(qos_profile, int) else qos_profile


def _latched(qos):
    return qos.durability == DurabilityPolicy.TRANSIENT_LOCAL


class LocalPublisher:
    """Publisher on the bus (the subset of rclpy.publisher.Publisher that nodes use)."""

    def __init__(self, bus, node, msg_type, topic, qos, dds):
        self.bus, self.node, self.msg_type, self.topic_name, self.qos_profile = bus, node, msg_type, topic, qos
        self.latched = _latched(qos)
        self.last = None  # last message of a transient-local publisher
        self.dds = dds    # rclpy Publisher when the bus also publishes on DDS
        self.routes, self.version = (), -1  # subscriptions to call, as of bus version
        self.publish = partial(bus.publish, self)  # publish(msg): the bus delivers it (no wrapper call per message)

    def get_subscription_count(self):
        return len(self.bus.subscriptions(self.topic_name, self.msg_type))

    def destroy(self):
        self.bus.remove(self)


class LocalSubscription:
    """Subscription on the bus: callback(msg), or callback(bytes) when raw."""

    def __init__(self, bus, node, msg_type, topic, callback, qos, raw):
        self.bus, self.node, self.msg_type, self.topic_name = bus, node, msg_type, topic
        self.callback, self.qos_profile, self.raw = callback, qos, raw

    def destroy(self):
        self.bus.remove(self)


class LocalBus:
    """The bus of one process: install() (or `with LocalBus():`) before the nodes are built, uninstall() after
    they are destroyed."""

    def __init__(self, publish_dds=False):
        self.publish_dds = publish_dds
        self.publishers = {}      # topic -> [LocalPublisher] in creation order
        self.subs = {}            # topic -> [LocalSubscription] in creation order
        self.time_sources = []    # TimeSources of sim-time nodes: their clocks follow the bus time
        self.timers = {}          # sim-time rclpy Timer -> due time (ns), in creation order
        self.topic_listeners = []
        self.now = 0              # bus time, ns (0: not started)
        self._synced = None       # bus time the rcl clocks of the time sources were last set to
        self.version = 0          # changes with every subscription created or removed (publishers' routes)
        self._pending = []        # (subscription, message) latched deliveries not made yet
        self._next_due = None
        self._target = 0
        self._advancing = False
        self._saved = {}
        self._now_patch = None
        self._time_ns, self._time = None, None  # the bus time of _time, an rclpy Time (immutable: shared)

    # -- installation ---------------------------------------------------------------------------------------------
    def install(self):
        global _installed
        if _installed is not None:
            raise RuntimeError("a LocalBus is already installed in this process")
        _installed = self
        for name in _PATCHED:
            self._saved[name] = getattr(Node, name)
            setattr(Node, name, self._patched(getattr(LocalBus, f"_node_{name}"), self._saved[name]))
        ROSClock.now = self._now_patch = self._patched(LocalBus._clock_now, ROSClock.now)
        return self

    def _patched(self, local, original):
        """A Node method that calls LocalBus.<local>(self, rclpy's method, node, ...)."""
        return lambda node, *args, **kwargs: local(self, original, node, *args, **kwargs)

    def uninstall(self):
        """Restore rclpy's Node methods and drop every reference to the nodes (graph and sim time)."""
        global _installed
        for name, original in self._saved.items():
            setattr(Node, name, original)
        self._saved.clear()
        if vars(ROSClock).get("now") is self._now_patch:
            del ROSClock.now  # rclpy's ROSClock inherits Clock.now
        for table in (self.publishers, self.subs, self.timers, self.topic_listeners, self.time_sources, self._pending):
            table.clear()
        if _installed is self:
            _installed = None

    def __enter__(self):
        return self.install()

    def __exit__(self, *exc):
        self.uninstall()

    # -- Node methods while installed (self: the bus, original: rclpy's method) -------------------------------------
    def _node_create_publisher(self, original, node, msg_type, topic, qos_profile, **kwargs):
        qos = _qos(qos_profile)
        name = node.resolve_topic_name(topic)
        dds = original(node, msg_type, topic, qos, **kwargs) if self.publish_dds else None
        pub = LocalPublisher(self, node, msg_type, name, qos, dds)
        new = name not in self.publishers
        self.publishers.setdefault(name, []).append(pub)
        for sub in self.subs.get(name, ()):
            self._check_types(pub, sub)
        if new:
            for listener in list(self.topic_listeners):
                listener()
        return pub

    def _node_create_subscription(self, original, node, msg_type, topic, callback, qos_profile, *,
                                  raw=False, **kwargs):
        qos = _qos(qos_profile)
        sub = LocalSubscription(self, node, msg_type, node.resolve_topic_name(topic), callback, qos, raw)
        owner = getattr(callback, "__self__", None)
        if sub.topic_name == CLOCK_TOPIC and isinstance(owner, TimeSource):
            self.time_sources.append(owner)  # its clocks follow the bus time, not messages
            self._synced = None  # its rcl clocks too, at the next _sync_clocks
            return sub
        self.subs.setdefault(sub.topic_name, []).append(sub)
        self.version += 1
        for pub in self.publishers.get(sub.topic_name, ()):
            if self._check_types(pub, sub) and pub.last is not None and _latched(qos):
                self._pending.append((sub, pub.last))
        return sub

    def _clock_now(self, original, clock):
        """ROSClock.now while installed: the bus time for the clock of a sim-time node (what its rcl clock would
        say once set), rclpy's for any other."""
        if any(clock in source._associated_clocks for source in self.time_sources):
            if self._time_ns != self.now:
                self._time_ns, self._time = self.now, Time(nanoseconds=self.now, clock_type=ClockType.ROS_TIME)
            return self._time
        return original(clock)

    def _node_create_timer(self, original, node, *args, **kwargs):
        timer = original(node, *args, **kwargs)
        if timer.clock.clock_type == ClockType.ROS_TIME and timer.clock.ros_time_is_active:
            self.timers[timer] = None
            self._update_dues()
        return timer

    def _node_destroy_publisher(self, original, node, publisher):
        if not isinstance(publisher, LocalPublisher):
            return original(node, publisher)
        return self.remove(publisher)

    def _node_destroy_subscription(self, original, node, subscription):
        if not isinstance(subscription, LocalSubscription):
            return original(node, subscription)
        return self.remove(subscription)

    def _node_count_publishers(self, original, node, topic_name):
        return len(self.publishers.get(node.resolve_topic_name(topic_name, only_expand=True), ()))

    def _node_count_subscribers(self, original, node, topic_name):
        return len(self.subs.get(node.resolve_topic_name(topic_name, only_expand=True), ()))

    def _node_get_topic_names_and_types(self, original, node, no_demangle=False):
        return [(topic, sorted({type_name(p.msg_type) for p in pubs}))
                for topic, pubs in sorted(self.publishers.items()) if pubs]

    def _node_get_publishers_info_by_topic(self, original, node, topic_name, no_mangle=False):
        return [SimpleNamespace(node_name=p.node.get_name(), node_namespace=p.node.get_namespace(),
                                topic_type=type_name(p.msg_type), qos_profile=p.qos_profile)
                for p in self.publishers.get(node.resolve_topic_name(topic_name, only_expand=True), ())]

    # -- graph ----------------------------------------------------------------------------------------------------
    def _check_types(self, pub, sub):
        if pub.msg_type is sub.msg_type:
            return True
        sub.node.get_logger().warning(f"{sub.topic_name}: subscription of type {type_name(sub.msg_type)} does not "
                                      f"match publisher type {type_name(pub.msg_type)} (not connected)")
        return False

    def subscriptions(self, topic, msg_type):
        return [s for s in self.subs.get(topic, ()) if s.msg_type is msg_type]

    def remove(self, entity):
        table = self.publishers if isinstance(entity, LocalPublisher) else self.subs
        entities = table.get(entity.topic_name, [])
        if entity not in entities:
            return False
        entities.remove(entity)
        self.version += 1
        if isinstance(entity, LocalPublisher) and entity.dds is not None:
            entity.node.destroy_publisher(entity.dds)
        return True

    # -- delivery -------------------------------------------------------------------------------------------------
    def publish(self, pub, msg):
        """Deliver `msg` (a pub.msg_type object, or its serialized bytes) to every matching subscription now."""
        serialized = isinstance(msg, bytes)
        if not serialized and type(msg) is not pub.msg_type:
            raise TypeError(f"{pub.topic_name}: expected {type_name(pub.msg_type)}, got {type(msg).__name__}")
        if self._pending:
            self.flush()
        if pub.latched:
            pub.last = msg
        if pub.dds is not None:
            pub.dds.publish(msg)
        if pub.topic_name == CLOCK_TOPIC:
            stamp = (from_cdr(msg, pub.msg_type) if serialized else msg).clock
            self.advance(stamp.sec * 1_000_000_000 + stamp.nanosec)
        if pub.version != self.version:  # subscriptions changed: (callback, raw, type) of the matching ones
            pub.routes = tuple((s.callback, s.raw, s.msg_type) for s in self.subs.get(pub.topic_name, ())
                               if s.msg_type is pub.msg_type)
            pub.version = self.version
        if serialized:  # a message object of its own for every subscription, as DDS gives
            for callback, raw, msg_type in pub.routes:
                callback(msg if raw else from_cdr(msg, msg_type))
            return
        data = None
        for callback, raw, _ in pub.routes:
            if raw and data is None:
                data = cdr(msg)
            callback(data if raw else msg)

    def flush(self):
        """Deliver the latched messages owed to subscriptions created after their publish."""
        while self._pending:
            sub, msg = self._pending.pop(0)
            if sub.raw and not isinstance(msg, bytes):
                msg = cdr(msg)
            elif not sub.raw and isinstance(msg, bytes):
                msg = from_cdr(msg, sub.msg_type)
            sub.callback(msg)

    # -- sim time -------------------------------------------------------------------------------------------------
    def advance(self, t_ns):
        """Move the bus time to t_ns: fire the sim-time timers due by then (each at its due time), then move on to
        t_ns (the node clocks read the bus time). Called for every /clock message; a call from a timer callback
        moves the target on."""
        if self._pending:
            self.flush()
        if t_ns < self.now:  # time went back (a looped replay): follow it, timers re-align
            self.now = t_ns
            self._update_dues()
            return
        self._target = max(self._target, t_ns)
        if self._advancing:
            return
        self._advancing = True
        try:
            if self.now == 0:  # the sim clock starts: timers created at time 0 are overdue and fire now
                self.now = self._target
                self._update_dues()
            while self._next_due is not None and self._next_due <= self._target:
                self.now = max(self._next_due, self.now)
                self._sync_clocks()
                for timer in [t for t, due in self.timers.items() if due is not None and due <= self.now]:
                    self._fire(timer)
                self._update_dues()
            if self._target > self.now:
                self.now = self._target
        finally:
            self._advancing = False

    def _sync_clocks(self):
        """Set the rcl clocks of the time sources to the bus time (the timers read them)."""
        if self._synced == self.now:
            return
        self._synced = self.now
        time = Time(nanoseconds=self.now, clock_type=ClockType.ROS_TIME)
        for source in self.time_sources:
            source._last_time_set = time  # what TimeSource.clock_callback does, without a message per node
            for clock in source._associated_clocks:
                clock.handle.set_ros_time_override(time._time_handle)  # ROSClock.set_ros_time_override

    def _update_dues(self):
        self._sync_clocks()
        for timer in list(self.timers):
            try:
                active = not timer.is_canceled() and timer.clock.ros_time_is_active
                until = timer.time_until_next_call() if active else None
            except Exception:  # destroyed with its node
                del self.timers[timer]
                continue
            self.timers[timer] = None if until is None else self.now + until
        self._next_due = min((d for d in self.timers.values() if d is not None), default=None)

    def _fire(self, timer):
        try:
            with timer.handle:
                timer.handle.call_timer()
        except Exception:  # destroyed or cancelled meanwhile
            self.timers.pop(timer, None)
            return
        if timer.callback is not None:
            timer.callback()

