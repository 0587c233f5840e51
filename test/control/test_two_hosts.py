"""Two computers on a tractor (issue 17, item 12): host A runs the sensor side (the bag player replaying the drivers'
topics of bags/rtk_straight_fast in real time), host B navigation + steering (`agnav run --live`). The hosts are two
network namespaces that this test creates (a user namespace: no root needed) joined by a veth pair; DDS stays inside
them (LOCALHOST discovery range + ROS_STATIC_PEERS of the other end, UDP only, no multicast; nothing else is
reachable from the namespaces). Once steering is engaged on odometry from across the link, the link is cut: the
steering watchdog must command neutral within 200 ms and diagnostics must raise on both hosts.

Run as a script inside the namespaces: `python test_two_hosts.py inside DIR` (host A, the orchestrator) and
`python test_two_hosts.py monitor FILE` (a listener writing what it hears as JSON lines)."""
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[2]
AGNAV = str(Path(sys.executable).with_name("agnav"))
A_IP, B_IP = "10.23.0.1", "10.23.0.2"
NEUTRAL_WITHIN = 0.2  # s from the cut to the first disengaged, zero-angle /steering/command
# Fast DDS participant lease (default 20 s) shortened, so that host A notices the lost readers within seconds
LEASE_XML = """<?xml version="1.0" encoding="UTF-8" ?>
<dds xmlns="http://www.eprosima.com"><profiles>
  <participant profile_name="two_hosts" is_default_profile="true"><rtps><builtin><discovery_config>
    <leaseDuration><sec>1</sec></leaseDuration>
    <leaseAnnouncement><sec>0</sec><nanosec>200000000</nanosec></leaseAnnouncement>
  </discovery_config></builtin></rtps></participant>
</profiles></dds>
"""


def namespaces_unavailable():
    """Why this machine cannot run the test (None: it can)."""
    for tool in ("unshare", "nsenter", "ip"):
        if shutil.which(tool) is None:
            return f"'{tool}' is not installed"
    probe = subprocess.run(["unshare", "-rn", "--fork", "sh", "-c",
                            "ip link add t0 type veth peer name t1 && ip link set t0 up"],
                           capture_output=True, text=True, timeout=30)
    if probe.returncode != 0:
        return f"user/network namespaces with a veth pair are not allowed here: {probe.stderr.strip()}"
    return None


@pytest.mark.timeout(240)
def test_graph_across_two_hosts_and_link_loss(tmp_path):
    reason = namespaces_unavailable()
    if reason:
        pytest.skip(reason)
    proc = subprocess.run(["unshare", "-rn", "--fork", sys.executable, __file__, "inside", str(tmp_path)],
                          capture_output=True, text=True, timeout=200)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    result = json.loads((tmp_path / "result.json").read_text())
    cut = result["cut"]
    b_heard = [json.loads(line) for line in (tmp_path / "b.jsonl").read_text().splitlines()]
    a_heard = [json.loads(line) for line in (tmp_path / "a.jsonl").read_text().splitlines()]
    odometry = [m for m in b_heard if m["topic"] == "/odometry/filtered" and m["t"] < cut]
    commands = [m for m in b_heard if m["topic"] == "/steering/command"]
    before = [m for m in commands if m["t"] < cut]
    assert len(odometry) > 100, "steering host got no odometry fused from the sensor host's streams"
    assert before and before[-1]["engaged"], "steering was not engaged before the cut"
    neutral = next(m for m in commands if m["t"] >= cut and not m["engaged"] and m["angle"] == 0.0)
    assert neutral["t"] - cut < NEUTRAL_WITHIN, neutral["t"] - cut
    assert all(not m["engaged"] and m["angle"] == 0.0 for m in commands if m["t"] >= neutral["t"])

    def raised(heard, node):
        return [m for m in heard if m["topic"] == "/diagnostics" and m["name"].startswith(f"{node}:")
                and m["level"] >= 1 and m["t"] >= cut]
    steering = raised(b_heard, "steering_node")
    assert steering and steering[0]["level"] == 2 and "fail-safe" in steering[0]["message"]
    assert steering[0]["t"] - cut < 1.0
    player = raised(a_heard, "bag_player")
    assert player and "subscribers lost" in player[0]["message"], a_heard[-5:]
    assert not [m for m in raised(a_heard, "bag_player") if m["t"] < cut]


# ---- inside the namespaces ------------------------------------------------------------------------------------
def monitor(out):
    """Write every /steering/command, /odometry/filtered and /diagnostics status heard here as JSON lines."""
    import rclpy
    from agnav_msgs.msg import SteeringCommand
    from diagnostic_msgs.msg import DiagnosticArray
    from nav_msgs.msg import Odometry

    from agnav_common.qos import SENSOR_QOS
    rclpy.init()
    node = rclpy.create_node("two_hosts_monitor")
    f = open(out, "w", buffering=1)  # noqa: SIM115  (closed at exit)

    def write(**row):
        f.write(json.dumps(dict(row, t=time.monotonic())) + "\n")
    node.create_subscription(SteeringCommand, "/steering/command", lambda m: write(
        topic="/steering/command", engaged=m.engaged, angle=m.steering_angle), SENSOR_QOS)
    node.create_subscription(Odometry, "/odometry/filtered", lambda m: write(topic="/odometry/filtered"), SENSOR_QOS)
    node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: [write(
        topic="/diagnostics", name=s.name, level=int.from_bytes(s.level, "little") if isinstance(s.level, bytes)
        else int(s.level), message=s.message) for s in m.status], 50)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, Exception):  # noqa: BLE001  (SIGINT ends the monitor)
        pass
    finally:
        f.close()
        rclpy.try_shutdown()


def configs(tmp):
    """Host B: steer.yaml's navigation and steering nodes on wall time; the mounts come from the bag's /tf_static
    across the link."""
    steer = yaml.safe_load((REPO / "src" / "agnav_bringup" / "config" / "steer.yaml").read_text())
    b = {"description": "navigation + steering host", "bag": "", "record": [], "static_transforms": [],
         "nodes": [n for n in steer["nodes"] if n["executable"] in ("nav_sensor_module_node", "steering_node")]}
    (tmp / "b.yaml").write_text(yaml.safe_dump(b))


def inside(tmp):
    """Host A's side of the test (run in a fresh user + network namespace)."""
    tmp = Path(tmp)
    configs(tmp)
    (tmp / "lease.xml").write_text(LEASE_XML)
    run = lambda *cmd: subprocess.run(cmd, check=True)  # noqa: E731
    run("ip", "link", "set", "lo", "up")
    holder = subprocess.Popen(["unshare", "-n", "sleep", "600"])  # host B's network namespace
    time.sleep(0.3)
    b_ns = ["nsenter", "-t", str(holder.pid), "-n"]
    run("ip", "link", "add", "vA", "type", "veth", "peer", "name", "vB", "netns", str(holder.pid))
    run("ip", "addr", "add", f"{A_IP}/24", "dev", "vA")
    run("ip", "link", "set", "vA", "up")
    run(*b_ns, "sh", "-c", f"ip link set lo up && ip addr add {B_IP}/24 dev vB && ip link set vB up")
    time.sleep(1.0)  # both ends up before DDS enumerates the interfaces
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", FASTDDS_BUILTIN_TRANSPORTS="UDPv4",
               FASTDDS_DEFAULT_PROFILES_FILE=str(tmp / "lease.xml"), ROS_LOG_DIR=str(tmp / "log"))
    env_a, env_b = dict(env, ROS_STATIC_PEERS=B_IP), dict(env, ROS_STATIC_PEERS=A_IP)
    me = [sys.executable, str(Path(__file__).resolve())]
    procs = [subprocess.Popen(b_ns + me + ["monitor", str(tmp / "b.jsonl")], env=env_b),
             subprocess.Popen(b_ns + [AGNAV, "run", str(tmp / "b.yaml"), "--live", "--quiet", "--duration", "90"],
                              env=env_b),
             subprocess.Popen(me + ["monitor", str(tmp / "a.jsonl")], env=env_a)]
    time.sleep(3.0)
    # the drivers' side: the bag player in real time, once host B's nodes subscribe every replayed topic (the
    # fusion then starts from the bag's first sample, as with drivers that run before it)
    procs.append(subprocess.Popen([str(Path(sys.executable).with_name("bag_player")), "--ros-args", "-p",
                                   f"bag:={REPO / 'bags' / 'rtk_straight_fast'}", "-p", "rate:=1.0", "-p",
                                   "min_subscribers:=1", "-p", "start_delay:=1.0", "-p",
                                   "exclude:=[/ground_truth/odometry, /gnss/status]"], env=env_a))
    cut, deadline = None, time.monotonic() + 70.0
    try:
        while cut is None and time.monotonic() < deadline:  # cut 3 s after steering first engages
            time.sleep(0.2)
            heard = [json.loads(line) for line in (tmp / "b.jsonl").read_text().splitlines() if line.endswith("}")]
            engaged = [m["t"] for m in heard if m["topic"] == "/steering/command" and m["engaged"]]
            if engaged and time.monotonic() - engaged[0] > 3.0:
                cut = time.monotonic()
                run("ip", "link", "set", "vA", "down")
        time.sleep(6.0)  # diagnostics of both hosts (the player notices the lost readers after the 1 s lease)
    finally:
        for proc in procs:
            proc.send_signal(2)
        for proc in procs:
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
        holder.kill()
    (tmp / "result.json").write_text(json.dumps({"cut": cut}))
    return 0 if cut is not None else 1


if __name__ == "__main__":
    sys.exit(inside(sys.argv[2]) if sys.argv[1] == "inside" else monitor(sys.argv[2]))
