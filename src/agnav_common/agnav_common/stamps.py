"""Header stamps: conversion and the guard every node applies to incoming measurement epochs."""
import math

from builtin_interfaces.msg import Time


def to_sec(stamp):
    """builtin_interfaces/Time -> float seconds."""
    return stamp.sec + stamp.nanosec * 1e-9


def to_stamp(seconds):
    """float seconds -> builtin_interfaces/Time."""
    ns = int(round(seconds * 1e9))
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class StampGuard:
    """Rejects zero, non-finite and backwards measurement stamps of one stream and counts them."""

    def __init__(self, allow_equal=False):
        self.last = None
        self.allow_equal = allow_equal
        self.rejected = 0

    def check(self, t):
        """None if the stamp `t` (s) is acceptable, else the reason it is rejected."""
        reason = None
        if not math.isfinite(t) or t <= 0.0:
            reason = f"invalid stamp {t}"
        elif self.last is not None and (t < self.last or (t == self.last and not self.allow_equal)):
            reason = f"stamp {t:.6f} not after previous {self.last:.6f}"
        if reason is None:
            self.last = t
        else:
            self.rejected += 1
        return reason
