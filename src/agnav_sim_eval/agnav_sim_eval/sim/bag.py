"""Write a simulated run to a rosbag2 (mcap, zstd chunks) with the INTERFACES.md topics."""
import shutil
from pathlib import Path

from agnav_common.qos import bag_profiles
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode, StoragePlugin

from .messages import MESSAGE_TYPES, run_rows


def record(sim, out_dir, overwrite=False):
    """Run `sim` (TractorSimulator, built-in driver) to its end and write the bag at out_dir; returns counts.

    Sensor messages are written at their stamp, GNSS at its arrival time (stamp = epoch), latched
    /tf_static and /map_datum first.
    """
    out = Path(out_dir)
    if out.exists():
        if not overwrite:
            raise FileExistsError(f"{out} exists (use --overwrite)")
        shutil.rmtree(out)
    factory, rows = run_rows(sim)
    counts = {}
    writer = Writer(out, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with writer:
        connections = {}
        for when, topic, msg in rows:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, MESSAGE_TYPES[topic], typestore=factory.ts,
                                                           offered_qos_profiles=bag_profiles(topic, None))
            writer.write(connections[topic], int(round((factory.t0 + when) * 1e9)), factory.serialize(topic, msg))
            counts[topic] = counts.get(topic, 0) + 1
    return counts
