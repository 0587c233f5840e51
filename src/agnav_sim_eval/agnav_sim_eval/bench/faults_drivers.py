"""Driver cases of `agnav bench faults --graph drivers`: GNSS driver nodes fed faulty byte streams through a
pseudo-terminal (agnav_drivers.pty_device), as a broken receiver or cable would.

Each case runs the driver as its own process (`nmea_gnss_node` / `ubx_gnss_node` main, default parameters, port
= the pty) in the bench's ROS_DOMAIN_ID and streams generated messages at real time, 5 epochs/s: NMEA GGA + RMC
(pynmea2 checksums) or UBX NAV-PVT (pyubx2), a tractor at 2 m/s near the position of the real u-blox ZED-F9P
capture. About 2 s of clean epochs after the first fix, 1 s of faulty epochs (or the pty unplugged for 1 s, then
a new pty behind the same path), 3 s clean. The bench records /gnss/fix, /gnss/vel and /diagnostics with their
receive times. Criteria per case:
(alive) the node runs to the end, exits 0 on SIGINT and logs no driver error or traceback once streaming (errors
before its first fix are counted apart as startup errors: a start-up race, not the fault's doing);
(plausible) every fix has a finite lat/lon within range and 10 km of the stream's path and a covariance either
unknown or with positive finite variances, or is NO_FIX with NaN lat/lon and an unknown covariance; every
velocity is finite, under 100 m/s, with positive finite variances;
(stream) a fix within 2 s after the fault ends (after a replug: the link's back-off cap, 2 s, + one epoch) and
no gap over 2 s between fixes from then to the end;
(diagnostics) within 1 s of the first faulty byte (or the unplug), /diagnostics shows the case's counter or state
changed (keys in the table);
(fresh) no fix or velocity stamped more than 0.5 s before it was received (no stale burst).
"""
import datetime as dt
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from agnav_sim_eval.bench.faults_streams import (LAT0, LON0, RATE_HZ, bad_checksum, epoch, gga, nmea_clean,
                                                 nmea_garbage, pvt, rmc, sentence)

PRE_S, FAULT_S, POST_S = 2.0, 1.0, 3.0
STREAM_GAP_S, DETECT_S, STALE_S = 2.0, 1.0, 0.5
BACKOFF_MAX = 2.0        # s, the nodes' default backoff_max (serial_link.LinkSettings)
MAX_SPEED = 100.0        # m/s, gnss_types.Limits.max_speed
NEAR_M = 10_000.0        # m from the stream's path: farther is a garbage position
NODES = {"nmea": ("agnav_drivers.nmea_gnss_node", "nmea_gnss", "nmea"),
         "ubx": ("agnav_drivers.ubx_gnss_node", "ubx_gnss", "ubx")}
CRITERIA = ("alive_ok", "plausible_ok", "stream_ok", "detected_ok", "fresh_ok")


@dataclass
class DriverCase:
    name: str
    driver: str                   # nmea | ubx
    fault: object = None          # epoch -> faulty bytes of that epoch (None: unplug/replug)
    keys: tuple = ()              # diagnostic values that must change (link: level ERROR also counts)
    what: str = ""


def cases():
    n, u = "nmea", "ubx"
    return [
        DriverCase("nmea_checksum_failures", n, lambda e: bad_checksum(gga(e)) + bad_checksum(rmc(e)),
                   ("checksum_failures",), "GGA and RMC with wrong checksums"),
        DriverCase("nmea_truncated_garbage", n, nmea_garbage, ("parse_errors", "noise_bytes", "checksum_failures"),
                   "truncated GGA, 80 binary bytes, a sentence without checksum, a 300-byte line"),
        DriverCase("nmea_lat_95", n, lambda e: sentence(gga(e, lat=95.0)) + sentence(rmc(e, lat=95.0)),
                   ("implausible", "rejected"), "GGA and RMC at latitude 95°"),
        DriverCase("nmea_speed_2000", n, lambda e: sentence(gga(e)) + sentence(rmc(e, knots=2000.0 / 0.514444)),
                   ("implausible", "rejected"), "RMC speed 2000 m/s"),
        DriverCase("nmea_no_fix_latlon_0", n, lambda e: sentence(gga(e, 0, 0.0, 0.0)) + sentence(rmc(e, "V", 0, 0, 0)),
                   ("fix_type",), "GGA quality 0 at lat/lon 0, RMC status V"),
        DriverCase("nmea_unplug_replug", n, None, ("state", "disconnects"), "pty closed 1 s, then a new one"),
        DriverCase("ubx_corrupt_length_8000", u, lambda e: b"\xb5\x62\x01\x07\x40\x1f" + b"\x00" * 10 + pvt(e),
                   ("corrupt_frames",), "NAV-PVT header claiming 8000 bytes before each frame"),
        DriverCase("ubx_corrupt_length_3000", u, lambda e: b"\xb5\x62\x01\x99\xb8\x0b" + pvt(e),
                   ("corrupt_frames",), "header of an unknown NAV id claiming 3000 bytes before each frame"),
        DriverCase("ubx_veln_2000000", u, lambda e: pvt(e, velN=2_000_000), ("implausible",),
                   "NAV-PVT velN 2,000,000 mm/s"),
        DriverCase("ubx_hacc_sacc_zero", u, lambda e: pvt(e, hAcc=0, vAcc=0, sAcc=0), ("floored_accuracy",),
                   "NAV-PVT hAcc = vAcc = sAcc = 0"),
        DriverCase("ubx_fixtype_0", u, lambda e: pvt(e, fixType=0, gnssFixOk=0, lat=0.0, lon=0.0),
                   ("fix_type",), "NAV-PVT fixType 0 at lat/lon 0"),
        DriverCase("ubx_unplug_replug", u, None, ("state", "disconnects"), "pty closed 1 s, then a new one"),
    ]


def clean_bytes(driver, e):
    return nmea_clean(e) if driver == "nmea" else pvt(e)


# ---- recording -------------------------------------------------------------------------------------
class Listener:
    """/gnss/fix, /gnss/vel, /diagnostics with receive times (time.time()), in its own rclpy context."""

    def __init__(self, domain):
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import TwistWithCovarianceStamped
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import NavSatFix

        from agnav_common.qos import SENSOR_QOS
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = rclpy.create_node("fault_bench_drivers", context=self.context)
        self.got = {"fix": [], "vel": [], "diag": []}
        self._lock = threading.Lock()
        for kind, typ, topic, qos in (("fix", NavSatFix, "/gnss/fix", SENSOR_QOS),
                                      ("vel", TwistWithCovarianceStamped, "/gnss/vel", SENSOR_QOS),
                                      ("diag", DiagnosticArray, "/diagnostics", 50)):
            self.node.create_subscription(typ, topic, lambda m, k=kind: self._add(k, m), qos)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self):
        while self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception:  # noqa: BLE001  (context shut down under the spin)
                return

    def _add(self, kind, msg):
        with self._lock:
            self.got[kind].append((time.time(), msg))

    def take(self):
        with self._lock:
            out = {k: list(v) for k, v in self.got.items()}
            for v in self.got.values():
                v.clear()
        return out

    def close(self):
        self.context.try_shutdown()
        self._thread.join(2.0)


def start_node(driver, port, domain):
    module = NODES[driver][0]
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(domain))
    return subprocess.Popen([sys.executable, "-c", f"import sys; from {module} import main; sys.exit(main())",
                             "--ros-args", "-p", f"port:={port}", "-p", "baud:=115200"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def stop_node(proc):
    """(alive before the stop, rc, stderr)."""
    alive = proc.poll() is None
    if alive:
        proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=10.0)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        return alive, "hung on SIGINT", err
    return alive, proc.returncode, err


# ---- scoring ---------------------------------------------------------------------------------------
def stamp(m):
    return m.header.stamp.sec + m.header.stamp.nanosec * 1e-9


def fix_problem(m):
    """Why a NavSatFix is implausible or a NO_FIX carrying a position, or None."""
    p, cov, kind = (m.latitude, m.longitude, m.altitude), m.position_covariance, m.position_covariance_type
    if m.status.status < 0:
        if any(math.isfinite(v) for v in p[:2]) or kind != 0:
            return f"NO_FIX with lat/lon {p[0]}, {p[1]}, covariance type {kind}"
        return None
    if not all(math.isfinite(v) for v in p) or abs(p[0]) > 90 or abs(p[1]) > 180:
        return f"position {p}"
    north = math.radians(p[0] - LAT0) * 6378137.0
    east = math.radians(p[1] - LON0) * 6378137.0 * math.cos(math.radians(LAT0))
    if math.hypot(east, north) > NEAR_M:
        return f"position {p[0]:.5f}, {p[1]:.5f}: {math.hypot(east, north) / 1000:.0f} km off the stream"
    if kind != 0 and not all(math.isfinite(cov[i]) and cov[i] > 0 for i in (0, 4, 8)):
        return f"covariance type {kind} with variances {cov[0]}, {cov[4]}, {cov[8]}"
    return None


def vel_problem(m):
    v, cov = m.twist.twist.linear, m.twist.covariance
    if not all(math.isfinite(x) for x in (v.x, v.y, v.z)) or math.hypot(v.x, v.y, v.z) > MAX_SPEED:
        return f"velocity {v.x:.1f}, {v.y:.1f}, {v.z:.1f} m/s"
    if not all(math.isfinite(cov[i]) and cov[i] > 0 for i in (0, 7, 14)):
        return f"velocity variances {cov[0]}, {cov[7]}, {cov[14]}"
    return None


def diag_rows(msgs, node):
    """[(receive time, {check: (level, {key: value})})] of one node's statuses."""
    rows = []
    for t, m in msgs:
        st = {s.name.split(": ", 1)[1]: (int.from_bytes(s.level, "little") if isinstance(s.level, bytes)
                                         else int(s.level), {kv.key: kv.value for kv in s.values})
              for s in m.status if s.name.startswith(node + ": ")}
        if st:
            rows.append((t, st))
    return rows


def detection(rows, keys, t_fault):
    """Seconds from t_fault to the first status showing `keys` changed (or the link in ERROR), or None."""
    before = {}
    for t, st in rows:
        values = {k: v for _, (_, vals) in st.items() for k, v in vals.items() if k in keys}
        link_error = "state" in keys and st.get("link", (0,))[0] >= 2
        if t < t_fault:
            before.update(values)
        elif link_error or any(k in before and before[k] != v for k, v in values.items()):
            return t - t_fault
    return None


def log_time(line):
    """The wall time of a ROS log line '[ERROR] [1795613267.63] [node]: ...', or None (e.g. a traceback)."""
    try:
        return float(line.split("] [", 1)[1].split("]", 1)[0])
    except (IndexError, ValueError):
        return None


def score(case, rec, t0, t1, t_end, node_result, problems, first_fix=None):
    alive, rc, err = node_result
    errors = [ln for ln in err.splitlines() if "Traceback" in ln or "driver error" in ln]
    startup = [ln for ln in errors if first_fix is not None and (log_time(ln) or math.inf) < first_fix]
    bad_lines = [ln for ln in errors if ln not in startup]
    fixes = [(t, m) for t, m in rec["fix"] if m.status.status >= 0]
    bad = [(t, fix_problem(m)) for t, m in rec["fix"]] + [(t, vel_problem(m)) for t, m in rec["vel"]]
    bad = [(t, p) for t, p in bad if p]
    stale = [t - stamp(m) for t, m in rec["fix"] + rec["vel"] if t - stamp(m) > STALE_S]
    after = sorted(t for t, _ in fixes if t >= t1)
    allowed = BACKOFF_MAX + 1.0 / RATE_HZ if case.fault is None else STREAM_GAP_S
    first = after[0] - t1 if after else None
    gaps = [b - a for a, b in zip(after, after[1:])] + ([t_end - after[-1]] if after else [])
    seen = detection(diag_rows(rec["diag"], NODES[case.driver][1]), set(case.keys), t0)
    r = {"graph": "drivers", "case": case.name, "driver": case.driver, "fault": case.what,
         "rc": rc, "alive": alive, "driver_errors": bad_lines[:3], "startup_errors": startup[:3],
         "fixes": len(rec["fix"]),
         "velocities": len(rec["vel"]), "no_fix_messages": len(rec["fix"]) - len(fixes),
         "bad_outputs": len(bad), "first_bad_output": bad[0][1] if bad else None,
         "first_fix_after_s": first, "allowed_s": allowed, "max_gap_after_s": max(gaps) if gaps else None,
         "detected_after_s": seen, "detect_keys": list(case.keys), "stale_outputs": len(stale),
         "max_staleness_s": max(stale) if stale else None, "bench_problems": problems}
    r.update(alive_ok=alive and rc == 0 and not bad_lines, plausible_ok=not bad,
             stream_ok=first is not None and first <= allowed and max(gaps) <= STREAM_GAP_S,
             detected_ok=seen is not None and seen <= DETECT_S, fresh_ok=not stale)
    r["crash"] = not r["alive_ok"]
    r["pass"] = all(r[k] for k in CRITERIA)
    return r


# ---- one case --------------------------------------------------------------------------------------
def run_case(case, listener, domain, tmp):
    from agnav_drivers.pty_device import PtyDevice
    dev = PtyDevice(str(Path(tmp) / f"{case.name}.tty"))
    lock, problems = threading.Lock(), []
    start_utc = dt.datetime.now(dt.timezone.utc).replace(microsecond=0)
    proc = start_node(case.driver, dev.path, domain)
    listener.take()
    k, t_start = 0, time.time()
    t0 = t1 = first_fix = None
    deadline = t_start + 20.0
    try:
        while True:
            now = time.time()
            if first_fix is None and listener.got["fix"]:
                first_fix = now
            if t0 is None and first_fix is not None and now >= first_fix + PRE_S:
                t0 = now
                if case.fault is None:
                    with lock:
                        dev.unplug()
            if t0 is not None and t1 is None and now >= t0 + FAULT_S:
                t1 = now
                if case.fault is None:
                    with lock:
                        dev.plug()
            if t1 is not None and now >= t1 + POST_S or (first_fix is None and now > deadline):
                break
            e = epoch(k, start_utc)
            faulty = t0 is not None and t1 is None and case.fault is not None
            with lock:
                if dev.plugged:
                    try:
                        dev.write(case.fault(e) if faulty else clean_bytes(case.driver, e))
                    except OSError as exc:
                        problems.append(f"write: {exc}")
            k += 1
            time.sleep(max(0.0, t_start + k / RATE_HZ - time.time()))
        t_end = time.time()
        time.sleep(0.3)  # last messages in flight
        result = stop_node(proc)
    finally:
        if proc.poll() is None:
            proc.kill()
        dev.close()
    rec = listener.take()
    if first_fix is None:
        problems.append("no fix within 20 s of the start (node did not come up)")
        t0 = t1 = t_end
    return score(case, rec, t0, t1, t_end, result, problems, first_fix)


def run(names=(), domain=0, keep=None):
    """Results of the driver cases (all, or those in `names`)."""
    chosen = [c for c in cases() if not names or c.name in names]
    results = []
    if not chosen:
        return results
    listener = Listener(domain)
    try:
        with tempfile.TemporaryDirectory(prefix="agnav_faults_drivers_") as tmp:
            for case in chosen:
                r = run_case(case, listener, domain, keep or tmp)
                results.append(r)
                print(f"faults: drivers {case.name}: {'PASS' if r['pass'] else 'fail'} (rc={r['rc']})", flush=True)
    finally:
        listener.close()
    return results


def totals(results):
    return {"cases": len(results), "passes": sum(r["pass"] for r in results),
            "crashes": sum(r["crash"] for r in results), "bad_outputs": sum(r["bad_outputs"] for r in results),
            "stale_outputs": sum(r["stale_outputs"] for r in results),
            "startup_error_cases": sum(1 for r in results if r["startup_errors"]),
            **{f"{k}_failures": sum(1 for r in results if not r[k]) for k in CRITERIA}}


def _f(v, fmt=".2f"):
    return "–" if v is None else format(v, fmt)


def _ok(r, key):
    return "ok" if r[key] else "**FAIL**"


def markdown(results, tot):
    lines = ["## Drivers (`--graph drivers`)", "", __doc__.split("\n\n", 1)[1].strip(), "",
             "| case | graph | pass | fault | alive (rc) | plausible: bad outputs | stream: first fix after s "
             "(max gap) | diagnostics s (keys) | fresh: stale outputs |", "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        first = f"{_f(r['first_fix_after_s'])} ≤ {r['allowed_s']:.1f} ({_f(r['max_gap_after_s'])})"
        lines.append(
            f"| {r['case']} | drivers | {'yes' if r['pass'] else '**no**'} | {r['fault']} "
            f"| {r['rc']}{', died' if not r['alive'] else ''}{', driver error' if r['driver_errors'] else ''}"
            f"{', startup error' if r['startup_errors'] else ''} {_ok(r, 'alive_ok')} "
            f"| {r['bad_outputs']} {_ok(r, 'plausible_ok')}"
            f"{' (' + r['first_bad_output'] + ')' if r['first_bad_output'] else ''} | {first} {_ok(r, 'stream_ok')} "
            f"| {_f(r['detected_after_s'])} ({', '.join(r['detect_keys'])}) {_ok(r, 'detected_ok')} "
            f"| {r['stale_outputs']} {_ok(r, 'fresh_ok')} |")
    lines += ["", f"Totals drivers: {tot['cases']} cases, {tot['passes']} pass, {tot['crashes']} crashes, "
              f"{tot['bad_outputs']} implausible outputs, {tot['stale_outputs']} stale outputs, "
              f"{tot['startup_error_cases']} cases with a driver error before the first fix; failures per "
              "criterion: " + ", ".join(f"{k[:-3]} {tot[k + '_failures']}" for k in CRITERIA) + "."]
    return "\n".join(lines) + "\n"
