"""Generated GNSS byte streams for the driver fault cases (bench/faults_drivers.py): NMEA GGA + RMC with pynmea2
checksums and UBX NAV-PVT with pyubx2, a tractor at SPEED m/s due east near the real ZED-F9P capture's position,
RATE_HZ epochs a second, and the faulty variants (bad checksums, garbage, impossible values)."""
import datetime as dt
import math
import random
from dataclasses import dataclass

import pynmea2
import pyubx2

RATE_HZ = 5.0
LAT0, LON0, ALT0, SPEED = -45.8775, 170.5028, 50.0, 2.0  # ZED-F9P capture (Dunedin); 2 m/s due east


@dataclass
class Epoch:
    k: int
    utc: dt.datetime
    lat: float
    lon: float


def epoch(k, start):
    east = SPEED * k / RATE_HZ
    return Epoch(k, start + dt.timedelta(seconds=k / RATE_HZ), LAT0,
                 LON0 + math.degrees(east / (6378137.0 * math.cos(math.radians(LAT0)))))


# ---- NMEA ------------------------------------------------------------------------------------------
def sentence(body):
    return f"${body}*{pynmea2.NMEASentence.checksum(body):02X}\r\n".encode()


def _dm(value, hemis, width):
    d = abs(value)
    return f"{int(d):0{width}d}{(d - int(d)) * 60:08.5f}", hemis[value < 0]


def gga(e, quality=1, lat=None, lon=None):
    la, ns = _dm(e.lat if lat is None else lat, "NS", 2)
    lo, ew = _dm(e.lon if lon is None else lon, "EW", 3)
    return f"GPGGA,{e.utc:%H%M%S}.{e.utc.microsecond // 10000:02d},{la},{ns},{lo},{ew},{quality},12,0.8," \
           f"{ALT0:.1f},M,7.0,M,,"


def rmc(e, status="A", knots=SPEED / 0.514444, lat=None, lon=None):
    la, ns = _dm(e.lat if lat is None else lat, "NS", 2)
    lo, ew = _dm(e.lon if lon is None else lon, "EW", 3)
    return f"GPRMC,{e.utc:%H%M%S}.{e.utc.microsecond // 10000:02d},{status},{la},{ns},{lo},{ew},{knots:.3f},90.0," \
           f"{e.utc:%d%m%y},,,{'A' if status == 'A' else 'N'}"


def nmea_clean(e):
    return sentence(gga(e)) + sentence(rmc(e))


def bad_checksum(body):
    good = sentence(body)
    return good[:-4] + (b"00" if good[-4:-2] != b"00" else b"11") + b"\r\n"


def nmea_garbage(e):
    rng = random.Random(e.k)
    return (sentence(gga(e))[:30] + sentence(rmc(e))  # truncated GGA glued to an RMC
            + bytes(rng.randrange(256) for _ in range(80)) + b"\r\n"  # binary noise
            + f"${gga(e)}\r\n".encode()  # no checksum
            + b"$GPGGA," + b"9" * 300 + b"\r\n")  # overlong line


# ---- UBX -------------------------------------------------------------------------------------------
def pvt(e, **over):
    fields = dict(iTOW=int((e.utc.timestamp() % 604800) * 1000), year=e.utc.year, month=e.utc.month,
                  day=e.utc.day, hour=e.utc.hour, min=e.utc.minute, second=e.utc.second, nano=e.utc.microsecond * 1000,
                  validDate=1, validTime=1, fullyResolved=1, fixType=3, gnssFixOk=1, numSV=18, lat=e.lat, lon=e.lon,
                  height=int(ALT0 * 1000), hMSL=int((ALT0 - 7.0) * 1000), hAcc=20, vAcc=30, velE=int(SPEED * 1000),
                  velN=0, velD=0, gSpeed=int(SPEED * 1000), sAcc=50, pDOP=120)
    fields.update(over)
    return pyubx2.UBXMessage("NAV", "NAV-PVT", 0, **fields).serialize()
