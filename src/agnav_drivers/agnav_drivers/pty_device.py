"""A pseudo-terminal standing in for a USB serial device, for tests and benchmarks (no ROS).

The driver opens `path`, a symlink to the pty slave, as udev's /dev/serial/by-id links do;
unplug() closes the pty (the driver's reads fail, the path vanishes) and plug() makes a new pty
behind the same path.
"""
from __future__ import annotations

import os
import time
import tty


class PtyDevice:
    def __init__(self, path: str):
        self.path = path
        self._master = self._slave = None
        self.plug()

    def plug(self):
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo / CR translation before the driver configures the port
        tmp = self.path + ".new"
        os.symlink(os.ttyname(self._slave), tmp)
        os.replace(tmp, self.path)

    def unplug(self):
        if self._master is None:
            return
        os.unlink(self.path)
        os.close(self._master)
        os.close(self._slave)
        self._master = self._slave = None

    @property
    def plugged(self) -> bool:
        return self._master is not None

    def write(self, data: bytes):
        view = memoryview(data)
        while view:
            view = view[os.write(self._master, view):]

    def stream(self, data: bytes, baud: int, chunk: int = 64, stop=None):
        """Writes `data` paced at `baud` (10 bits per byte) in chunks."""
        for i in range(0, len(data), chunk):
            if stop is not None and stop.is_set():
                return
            self.write(data[i:i + chunk])
            time.sleep(len(data[i:i + chunk]) * 10.0 / baud)

    def close(self):
        self.unplug()
