"""rosbag2 helpers for agnav: the type store (ROS 2 Kilted standard types plus agnav_msgs and tf2_msgs from .msg
files), bag filtering, and recordings that survive a killed recorder (flushed chunks, recover_bag)."""
import os
import shutil
import sys
from functools import lru_cache
from io import BytesIO
from pathlib import Path

from rosbags.typesys import Stores, get_typestore, get_types_from_msg

INTERFACE_PACKAGES = ("agnav_msgs", "tf2_msgs")


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
    store = get_typestore(Stores.ROS2_KILTED)
    types = {}
    for package in INTERFACE_PACKAGES:
        for name, text in msg_definitions(package).items():
            if name not in store.types:
                types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


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


MCAP_MAGIC = b"\x89MCAP0\r\n"


def flush_recording(writer):
    """Put the pending chunk of a rosbags mcap Writer on disk now (rosbags holds up to 1 MiB in memory until
    close), so that a recording killed later keeps everything flushed; recover_bag finishes such a file."""
    storage = writer.storage
    if storage is not None and storage.chunk.msgs:  # rosbags 0.11 McapWriter internals (pinned)
        storage.close_chunk()
        storage.bio.flush()
        os.fsync(storage.bio.fileno())


def unfinished(path):
    """True for a rosbag2 folder whose writer never finished: an .mcap file but no metadata.yaml."""
    path = Path(path)
    return path.is_dir() and not (path / "metadata.yaml").exists() and any(path.glob("*.mcap"))


def _records(f):
    """(opcode, body) of the complete mcap records read from f; ends at a cut-off record, DataEnd or Footer."""
    while True:
        head = f.read(9)
        if len(head) < 9:
            return
        op, size = head[0], int.from_bytes(head[1:], "little")
        body = f.read(size)
        if len(body) < size or op in (0x0F, 0x02):
            return
        yield op, body


def _u(b, at, n):
    return int.from_bytes(b[at:at + n], "little")


def _string(b, at):
    """(text, offset after it) of the mcap string (u32 length + bytes) at `at`."""
    return b[at + 4:at + 4 + _u(b, at, 4)].decode(), at + 4 + _u(b, at, 4)


def _flat_records(f):
    """Complete records with chunks opened (uncompressed chunks, as agnav's recorder writes them)."""
    for op, body in _records(f):
        if op != 0x06:
            yield op, body
            continue
        compression, at = _string(body, 28)
        if compression:
            raise ValueError(f"compressed ({compression}) chunks are not supported")
        yield from _records(BytesIO(body[at + 8:at + 8 + _u(body, at, 8)]))


def _copy_records(f, writer):
    """Schemas, channels and messages of the mcap stream f into a rosbags Writer; returns the message count."""
    from rosbags.rosbag2.storage_mcap import get_qos

    store, schemas, conns, count = typestore(), {}, {}, 0
    for op, b in _flat_records(f):
        if op == 0x03:  # schema: id u16, name, encoding, data
            name, at = _string(b, 2)
            schemas[_u(b, 0, 2)] = (name, _string(b, _string(b, at)[1])[0])
        elif op == 0x04 and _u(b, 2, 2) in schemas:  # channel: id u16, schema id u16, topic, encoding, metadata
            msgtype, msgdef = schemas[_u(b, 2, 2)]
            topic, at = _string(b, 4)
            encoding, at = _string(b, at)
            conns[_u(b, 0, 2)] = writer.add_connection(
                topic, msgtype, msgdef=msgdef, serialization_format=encoding,
                rihs01=store.hash_rihs01(msgtype) if msgtype in store.types else "unknown",
                offered_qos_profiles=get_qos(b[at + 4:at + 4 + _u(b, at, 4)]))
        elif op == 0x05 and _u(b, 0, 2) in conns:  # message: channel u16, sequence u32, log time u64, publish time
            writer.write(conns[_u(b, 0, 2)], _u(b, 6, 8), b[22:])
            count += 1
    return count


def recover_bag(path):
    """Finish the rosbag2 folder of a killed recording (mcap without summary, no metadata.yaml) in place: every
    complete record is kept, the cut-off tail dropped. Returns the number of messages kept."""
    from rosbags.rosbag2 import Writer
    from rosbags.rosbag2.enums import StoragePlugin

    path = Path(path)
    if (path / "metadata.yaml").exists():
        raise ValueError(f"{path} is a finished recording (it has a metadata.yaml)")
    files = sorted(path.glob("*.mcap")) if path.is_dir() else []
    if len(files) != 1:
        raise ValueError(f"{path}: expected a folder with the one .mcap file of an unfinished recording, "
                         f"found {len(files)} .mcap files")
    tmp = path.parent / f".{path.name}.recovering"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        with files[0].open("rb") as f, Writer(tmp / path.name, version=9, storage_plugin=StoragePlugin.MCAP) as w:
            magic = f.read(8)
            if magic != MCAP_MAGIC:
                raise ValueError(f"{files[0]} is empty: the run was killed before its first write to disk"
                                 if not magic else f"{files[0]} is not an mcap file")
            count = _copy_records(f, w)
        done = tmp / path.name
        os.replace(done / f"{path.name}.mcap", path / f"{path.name}.mcap")  # replaces the unfinished file
        if files[0].name != f"{path.name}.mcap":
            files[0].unlink()
        os.replace(done / "metadata.yaml", path / "metadata.yaml")  # last: marks the folder finished
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return count
