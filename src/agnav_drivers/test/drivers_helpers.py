"""Shared helpers for the driver tests: real corpus lines and checksum fixing."""
from __future__ import annotations

import glob
import os
import re

import pynmea2

CORPUS = "/work/shared/data/real/gpsd_nmea"
CORPUS_FILES = sorted(glob.glob(os.path.join(CORPUS, "*.log")))
_SENTENCE = re.compile(rb"\$[A-Z]{5},[^\r\n$*]*\*[0-9A-F]{2}")


def with_checksum(body: str) -> bytes:
    """'GPGGA,...' -> b'$GPGGA,...*hh\\r\\n'."""
    return f"${body}*{pynmea2.NMEASentence.checksum(body):02X}\r\n".encode()


def real_sentences(name: str, kind: str) -> list[str]:
    """Bodies (no '$', no checksum) of well-formed `kind` sentences in one capture."""
    with open(os.path.join(CORPUS, name), "rb") as f:
        data = f.read()
    out = []
    for m in _SENTENCE.finditer(data):
        text = m.group().decode()
        if text[3:6] == kind:
            try:
                pynmea2.parse(text, check=True)
            except pynmea2.ParseError:
                continue
            out.append(text[1:-3])
    return out
