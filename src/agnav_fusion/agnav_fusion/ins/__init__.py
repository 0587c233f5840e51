"""Wander-azimuth strapdown INS with the 16-state error EKF, loosely coupled to GNSS (SPEC §7).

ROS-free core. Internal conventions follow the INS report: body B = FRD, computer frame C =
wander-azimuth (NWU rotated by the wander angle alpha about up), local level L = NED, heading
clockwise from true north. Conversion to REP-103 happens only in `frames.py` / the node.
"""
from .ekf import InsEkf, InsEkfSettings
from .mechanization import InsState, Mechanization
from .measurements import GnssSample

__all__ = ["GnssSample", "InsEkf", "InsEkfSettings", "InsState", "Mechanization"]
