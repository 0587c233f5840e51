"""rosbag2 helpers for agnav: the type store (ROS 2 Kilted standard types plus agnav_msgs and tf2_msgs from .msg
files), CDR coders for rclpy messages, and bag filtering (recordings that survive a killed recorder:
mcap_recording)."""
import array
import hashlib
import importlib
import itertools
import json
import os
import struct
import sys
import tempfile
import threading
from functools import lru_cache
from io import BytesIO
from pathlib import Path

import numpy
import rosbags.typesys
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

INTERFACE_PACKAGES = ("agnav_msgs", "tf2_msgs")
STORE = Stores.ROS2_KILTED


def _share_dirs():
    """Install prefixes to search for interface definitions: the venv, then AMENT_PREFIX_PATH."""
    prefixes = [sys.prefix] + os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)
    return [Path(p) / "share" for p in prefixes if p]


def msg_definitions(package):
    """{'pkg/msg/Name': text} for every .msg file of an installed interface package."""
    for share in _share_dirs():
        folder = share / package / "msg"
        if folder.is_dir():
            return {f"{package}/msg/{f.stem}": f.read_text() for f in sorted(folder.glob("*.msg"))}
    raise FileNotFoundError(f"interface package {package} is not installed (run `make setup`)")


@lru_cache(maxsize=1)
def typestore():
    """Kilted type store with the project's interfaces registered (cached)."""
    store = get_typestore(STORE)
    types = {}
    for package in INTERFACE_PACKAGES:
        for name, text in msg_definitions(package).items():
            if name not in store.types:
                types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


_definitions = {}  # "file": the cache file of definition(), "types": msgtype -> [msgdef, rihs01] or None
_DEFINITIONS_LOCK = threading.Lock()


def _definitions_file():
    """The cache file of definition(), named by what the store is built from: rosbags' store modules (their sizes
    and times) and the interface files."""
    key = hashlib.sha256(STORE.value.encode())
    for f in sorted((Path(rosbags.typesys.__file__).parent / "stores").glob("*.py")):
        key.update(f"{f.name} {f.stat().st_size} {f.stat().st_mtime_ns}".encode())
    for package in INTERFACE_PACKAGES:
        key.update(json.dumps(msg_definitions(package), sort_keys=True).encode())
    return Path(tempfile.gettempdir()) / "agnav_msgdefs" / f"{key.hexdigest()[:16]}.json"


def definition(msgtype):
    """(msgdef, rihs01) of msgtype as rosbags' Writer.add_connection derives them from typestore() (its ROS 2
    message definition and type hash), None for a type the store does not know. Cached on disk: building the
    store costs ~0.1 s of every recording's start-up. Thread-safe (a driver's reader thread publishes too)."""
    with _DEFINITIONS_LOCK:
        if not _definitions:
            path = _definitions["file"] = _definitions_file()
            try:
                _definitions["types"] = json.loads(path.read_text())
            except (OSError, ValueError):
                _definitions["types"] = {}
        types = _definitions["types"]
        if msgtype not in types:
            store = typestore()
            types[msgtype] = ([store.generate_msgdef(msgtype, ros_version=2)[0], store.hash_rihs01(msgtype)]
                              if msgtype in store.types else None)
            path = _definitions["file"]
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
            with os.fdopen(fd, "w") as f:
                f.write(json.dumps(types))
            os.replace(tmp, path)  # whole files only, whoever writes last
        return types[msgtype]


def type_name(msg_type):
    """'sensor_msgs/msg/Imu' of the rclpy class sensor_msgs.msg.Imu."""
    package, kind = msg_type.__module__.split(".")[:2]
    return f"{package}/{kind}/{msg_type.__name__}"


_WRITERS = {}  # rclpy class -> (msgtype, generated CDR writer or None: rclpy bytes through rosbags)


def cdr(msg):
    """CDR bytes of an rclpy message with zeroed alignment padding, as DDS sends them: rclpy's serialize_message
    leaves heap garbage in the padding, so its bytes are not reproducible. A writer generated from the message
    definition (its padding is zeros by construction; checked on the first message of each type: rclpy reads its
    bytes back as an equal message), else rclpy bytes -> rosbags message -> bytes (the slow way, for types it does
    not write); types rosbags does not know: rclpy's bytes."""
    known = _WRITERS.get(type(msg))
    if known is None:
        msgtype = type_name(type(msg))
        if definition(msgtype) is None:
            from rclpy.serialization import serialize_message
            return serialize_message(msg)
        from rclpy.serialization import deserialize_message
        try:
            writer = _Coder(type(msg), "write").function
            ok = deserialize_message(_written(writer, msg), type(msg)) == msg
        except Exception:  # noqa: BLE001  (an unsupported field)
            ok = False
        _WRITERS[type(msg)] = known = msgtype, writer if ok else None
    msgtype, writer = known
    return _round_trip(msg, msgtype) if writer is None else _written(writer, msg)


def _written(writer, msg):
    buf = bytearray(b"\x00\x01\x00\x00")  # CDR little endian
    writer(msg, buf)
    return bytes(buf)


def _round_trip(msg, msgtype):
    from rclpy.serialization import serialize_message
    store = typestore()
    return bytes(store.serialize_cdr(store.deserialize_cdr(serialize_message(msg), msgtype), msgtype))


# rclpy field type -> struct code (scalars), numpy dtype (fixed arrays), array typecode (sequences)
_SCALAR = {"double": "d", "float": "f", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H", "int32": "i",
           "uint32": "I", "int64": "q", "uint64": "Q", "boolean": "?", "octet": "c"}
_NUMERIC = {"double": "float64", "float": "float32", "int8": "int8", "uint8": "uint8", "int16": "int16",
            "uint16": "uint16", "int32": "int32", "uint32": "uint32", "int64": "int64", "uint64": "uint64"}
_ARRAY = {"double": "d", "float": "f", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H", "int32": "i",
          "uint32": "I", "int64": "q", "uint64": "Q"}
_READERS = {}  # rclpy class -> generated CDR reader, or None: rclpy's deserialize_message does it


def from_cdr(data, msg_type):
    """rclpy message of type msg_type from CDR bytes: what rclpy's deserialize_message returns (checked on the first
    message of each type), built about 3x faster (no default construction of every field that is then replaced).
    Types with fields it does not read (char, wstring, byte/bool arrays) and big-endian bytes go to rclpy; bytes that
    are no msg_type raise rclpy's error (before anything is cached)."""
    reader = _READERS.get(msg_type, from_cdr)          # from_cdr: not checked yet
    if reader is not None and reader is not from_cdr and data[1] == 1:
        return reader(memoryview(data)[4:], 0)[0]
    from rclpy.serialization import deserialize_message
    expected = deserialize_message(data, msg_type)
    if reader is from_cdr and data[1] == 1:
        try:
            reader = _Coder(msg_type, "read").function
            ok = reader(memoryview(data)[4:], 0)[0] == expected
        except Exception:  # noqa: BLE001  (an unsupported field)
            ok = False
        _READERS[msg_type] = reader if ok else None
    return expected


def _layout(cls):
    """The fields of an rclpy message class as CDR items: ('scalar', name, struct code, size), ('string', name),
    ('array', name, dtype, n, size), ('sequence', name, typecode, size), ('message', name, class),
    ('messages', name, class) for a sequence of messages. TypeError: unsupported."""
    def message(ftype):
        package, name = ftype.split("/")
        return getattr(importlib.import_module(f"{package}.msg"), name)

    items = []
    for name, ftype in cls.get_fields_and_field_types().items():
        base, _, rest = ftype.partition("[")
        if ftype in _SCALAR:
            items.append(("scalar", name, _SCALAR[ftype], struct.calcsize(_SCALAR[ftype])))
        elif base == "string" or base.startswith("string<="):
            items.append(("string", name))
        elif rest and base in _NUMERIC:
            items.append(("array", name, _NUMERIC[base], int(rest[:-1]), struct.calcsize(_ARRAY[base])))
        elif ftype.startswith("sequence<") and ftype[9:-1].split(",")[0] in _ARRAY:
            code = _ARRAY[ftype[9:-1].split(",")[0]]
            items.append(("sequence", name, code, struct.calcsize(code)))
        elif ftype.startswith("sequence<") and "/" in ftype:
            items.append(("messages", name, message(ftype[9:-1].split(",")[0])))
        elif "/" in ftype and not rest:
            items.append(("message", name, message(ftype)))
        else:
            raise TypeError(f"unsupported field {name}: {ftype}")
    return items


class _Coder:
    """`_Coder(cls, "read").function`: a generated `read(mv, pos) -> (message, pos)` (pos relative to the CDR payload);
    "write": `write(msg, buf)` (appends to a bytearray that starts with the encapsulation header). Nested messages are
    inlined, and a run of scalars whose sizes do not grow is one struct call: CDR aligns every scalar to its size and
    nothing else (no struct padding), so only the run's first scalar needs aligning. Where the position modulo the
    alignment is known when generating (up to the first string or sequence) the padding is a constant."""

    def __init__(self, cls, kind):
        self.read = kind == "read"
        self.env = {"new": object.__new__, "unpack": struct.unpack_from, "pack": struct.pack, "numpy": numpy,
                    "array": array.array, "ZEROS": [bytes(n) for n in range(8)]}
        self.lines, self.run, self.ids = [], [], itertools.count()
        self.at = (0, 8)  # the position is known to be at[0] modulo at[1] (payload start: 0 modulo 8)
        self.lines += ["def read(mv, pos):"] + self.new("o", cls, "  ") if self.read else ["def write(o, buf):"]
        self.fields(cls, "o", "  ")
        self.flush("  ")
        exec("\n".join(self.lines + (["  return o, pos"] if self.read else [])), self.env)  # noqa: S102
        self.function = self.env[kind]

    def new(self, var, cls, indent):
        """Code creating the message `var` of class cls (a reader's)."""
        n = next(self.ids)
        self.env[f"c{n}"], self.env[f"k{n}"] = cls, cls()._check_fields
        return [f"{indent}{var} = new(c{n})", f"{indent}{var}._check_fields = k{n}"]

    def align(self, size, indent):
        """Code aligning the position to `size` (buf holds the 4-byte encapsulation header before the payload)."""
        m, a = self.at
        if size == 1:
            return []
        if a >= size:  # known: a constant padding, if any
            pad = -m % size
            self.at = ((m + pad) % a, a)
            return [] if not pad else [f"{indent}pos += {pad}" if self.read else f"{indent}buf += ZEROS[{pad}]"]
        self.at = (0, size)
        return [f"{indent}pos = (pos + {size - 1}) & -{size}" if self.read
                else f"{indent}buf += ZEROS[-(len(buf) - 4) % {size}]"]

    def advance(self, size):
        """The position moves on by a known number of bytes (None: by an unknown one)."""
        m, a = self.at
        self.at = (0, 1) if size is None else ((m + size) % a, a)

    def flush(self, indent):
        """Code for the pending run of scalars [(field, struct code, size)]."""
        if not self.run:
            return
        fields, fmt = ", ".join(f for f, _, _ in self.run), "<" + "".join(c for _, c, _ in self.run)
        self.lines += self.align(self.run[0][2], indent) + (
            [f"{indent}{fields}, = unpack('{fmt}', mv, pos)", f"{indent}pos += {struct.calcsize(fmt)}"] if self.read
            else [f"{indent}buf += pack('{fmt}', {fields})"])
        self.advance(struct.calcsize(fmt))
        self.run = []

    def count(self, var, field, indent):
        """Code for an element count: read into `var`, or written as len(field)."""
        lines = self.align(4, indent) + ([f"{indent}{var} = unpack('<I', mv, pos)[0]", f"{indent}pos += 4"]
                                         if self.read else [f"{indent}buf += pack('<I', len({field}))"])
        self.advance(4)
        return lines

    def fields(self, cls, obj, i):
        """Code for the fields of message `obj` (a local variable) of class cls, indented by i."""
        read, lines = self.read, self.lines
        for item in _layout(cls):
            kind, f = item[0], f"{obj}._{item[1]}"
            if kind == "scalar":
                if self.run and item[3] > self.run[-1][2]:
                    self.flush(i)
                self.run.append((f, item[2], item[3]))
                continue
            if kind == "message":  # its scalars may continue the run
                sub = f"m{next(self.ids)}"
                lines += self.new(sub, item[2], i) + [f"{i}{f} = {sub}"] if read else [f"{i}{sub} = {f}"]
                self.fields(item[2], sub, i)
                continue
            self.flush(i)
            n = f"n{next(self.ids)}"  # an element count (read) or encoded string (write)
            if kind == "string":
                lines += (self.count(n, f, i) + [f"{i}{f} = str(mv[pos:pos + {n} - 1], 'utf-8')", f"{i}pos += {n}"]
                          if read else self.align(4, i) + [f"{i}{n} = {f}.encode()",
                                                           f"{i}buf += pack('<I', len({n}) + 1)", f"{i}buf += {n}",
                                                           f"{i}buf += ZEROS[1]"])
                self.advance(None)
            elif kind == "array":
                dtype, size, end = item[2], item[4], item[3] * item[4]
                lines += self.align(size, i) + (
                    [f"{i}{f} = numpy.frombuffer(mv, numpy.{dtype}, {item[3]}, pos).copy()", f"{i}pos += {end}"]
                    if read else [f"{i}if len({f}) != {item[3]}:", f"{i}  raise ValueError('{item[1]}')",
                                  f"{i}buf += numpy.asarray({f}, numpy.{dtype}).tobytes()"])
                self.advance(end)
            elif kind == "sequence":
                code, size = item[2:]
                lines += self.count(n, f, i) + (
                    [f"{i}{f} = array('{code}')", f"{i}if {n}:"] + self.align(size, i + "  ")
                    + [f"{i}  {f}.frombytes(mv[pos:pos + {n} * {size}])", f"{i}  pos += {n} * {size}"]
                    if read else [f"{i}if len({f}):"] + self.align(size, i + "  ")
                    + [f"{i}  buf += array('{code}', {f}).tobytes()"])
                self.advance(None)
            else:  # a sequence of messages: the element's code in a loop
                sub = f"m{next(self.ids)}"
                lines += self.count(n, f, i) + ([f"{i}{f} = {n}_items = []", f"{i}for _ in range({n}):"]
                                                + self.new(sub, item[2], i + "  ") + [f"{i}  {n}_items.append({sub})"]
                                                if read else [f"{i}for {sub} in {f}:"])
                self.advance(None)  # each pass starts where the last one ended
                self.fields(item[2], sub, i + "  ")
                self.flush(i + "  ")
                self.advance(None)


def filter_bag(src, dst, keep):
    """Copy the rosbag2 at src to dst (mcap) with the messages for which keep(topic, t_ns) is true; every
    connection keeps its type and offered QoS (latched topics stay latched)."""
    from rosbags.rosbag2 import Reader, Writer
    from rosbags.rosbag2.enums import StoragePlugin

    store = typestore()
    with Reader(src) as reader, Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        out = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store,
                                           offered_qos_profiles=c.ext.offered_qos_profiles)
               for c in reader.connections}
        for c, t, raw in reader.messages():
            if keep(c.topic, t):
                writer.write(out[c.id], t, raw)


def static_transforms(bag):
    """[{parent, child, xyz, rpy}] of the bag's /tf_static (the mounts a graph is given; the graph config's form)."""
    from rosbags.highlevel import AnyReader

    from agnav_common.frames import euler_from_quaternion

    out = []
    with AnyReader([Path(bag)], default_typestore=typestore()) as reader:
        conns = [c for c in reader.connections if c.topic == "/tf_static"]
        for conn, _, raw in reader.messages(connections=conns):
            for t in reader.deserialize(raw, conn.msgtype).transforms:
                tr, q = t.transform.translation, t.transform.rotation
                out.append({"parent": t.header.frame_id, "child": t.child_frame_id, "xyz": [tr.x, tr.y, tr.z],
                            "rpy": [float(a) for a in euler_from_quaternion(q.x, q.y, q.z, q.w)]})
    return out
