"""mcap recordings that survive a killed recorder: chunks flushed while recording (fsync'ed in the background),
message records written straight into the rosbags Writer's chunk, and recover_bag / unfinished for a recording
whose writer never closed."""
import os
import shutil
import struct
import threading
from io import BytesIO
from pathlib import Path

from agnav_common.bagio import typestore


MCAP_MAGIC = b"\x89MCAP0\r\n"


def flush_recording(writer, background=False):
    """Put the pending chunk of a rosbags mcap Writer on disk now (rosbags holds up to 1 MiB in memory until
    close), so that a recording killed later keeps everything flushed; recover_bag finishes such a file.
    background: the file is written now (a killed process loses nothing of it) and fsync'ed by a thread, which
    close_recording() waits for (a fast replay does not wait for the disk)."""
    storage = writer.storage
    if storage is not None and storage.chunk.msgs:  # rosbags 0.11 McapWriter internals (pinned)
        storage.close_chunk()
        storage.bio.flush()
        _wait_synced(writer)
        if background:
            writer._agnav_sync = threading.Thread(target=os.fsync, args=(storage.bio.fileno(),), daemon=True)
            writer._agnav_sync.start()
        else:
            os.fsync(storage.bio.fileno())


def _wait_synced(writer):
    sync = getattr(writer, "_agnav_sync", None)
    if sync is not None:
        sync.join()
        writer._agnav_sync = None


def close_recording(writer):
    """Close a rosbags Writer once a background fsync of flush_recording has finished."""
    _wait_synced(writer)
    writer.close()


_MESSAGE = struct.Struct("<BQHIQQ")  # mcap Message record: opcode, length, channel, sequence, log and publish time


def write_message(writer, connection, t_ns, data):
    """Writer.write(connection, t_ns, data) of an open, uncompressed rosbags mcap Writer, minus its per-message
    checks and record buffers: the same file (rosbags 0.11 Writer.write + McapWriter.write, pinned; checked by
    test/foundation/test_deterministic_replay.py)."""
    storage = writer.storage
    chunk, cid = storage.chunk, connection.id
    if t_ns < storage.message_start_time:
        storage.message_start_time = t_ns
    if t_ns > storage.message_end_time:
        storage.message_end_time = t_ns
    storage.channel_stats[cid] += 1
    if t_ns < chunk.message_start_time:
        chunk.message_start_time = t_ns
    if t_ns > chunk.message_end_time:
        chunk.message_end_time = t_ns
    bio = chunk.bio
    chunk.msgs[cid].append((t_ns, bio.tell()))
    bio.write(_MESSAGE.pack(0x05, 22 + len(data), cid, 0, t_ns, t_ns) + data)
    writer.counts[cid] += 1
    if t_ns < writer.min_timestamp:
        writer.min_timestamp = t_ns
    if t_ns > writer.max_timestamp:
        writer.max_timestamp = t_ns
    if bio.tell() > 2**20:
        storage.close_chunk()


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

