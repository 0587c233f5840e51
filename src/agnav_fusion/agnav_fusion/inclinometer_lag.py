"""Online identification of an inclinometer's first-order time constant from the gyro (agnav; SPEC §11.6 lag model).

The inclinometer reads y = L_tau[theta + a/g] (+ zero error, noise): its own angle lagged by tau. High-passed alike
(first order, `highpass` s), the gyro integrates to the high-passed angle without its bias, so over a grid of tau the
residual y_hp - L_tau[theta_hp + a_hp/g] is smallest at the sensor's own time constant; its mean square, averaged over
`window` s, is compared across the grid. The angular motion needed (sway, turns, rolling terrain) is not always
there: the estimate is reported only when the best tau stands out of its neighbours by `contrast`, and refined by a
parabola through the three best grid points (log tau).
"""
import math
from dataclasses import dataclass

import numpy as np


@dataclass
class LagIdentifierSettings:
    span: float = 6.0            # the grid covers tau / span .. tau x span around the configured tau (1.1 s: a
    #                              D5R's 0.3-1.5 s lies two points inside, where a minimum counts)
    points: int = 21             # grid points, log-spaced (ratio 1.2)
    highpass: float = 5.0        # s, first-order high-pass of angle, acceleration and reading (removes bias, zero)
    window: float = 15.0         # s, averaging time of the squared residuals
    contrast: float = 1.1        # mean square two grid points either side over the best one, to report the best
    settle: float = 6.0          # s of inclinometer data before the first estimate
    step: float = 0.05           # s, the grid's step (means of the high-passed signals over it)


class LagIdentifier:
    """update() per sample (gyro angle rate, reading or None, acceleration term a/g, dt); `tau` is the identified
    time constant, or None while the data do not tell it. The grid runs on `step`-s means of the high-passed
    signals (cost), the high-passes on every sample."""

    def __init__(self, tau, settings=None):
        self.settings = s = settings or LagIdentifierSettings()
        self.grid = tau * s.span ** np.linspace(-1.0, 1.0, s.points)
        self.log_grid = np.log(self.grid)
        self._dt, self._lag, self._keep = None, None, None   # per-sample dt, its grid lag factors and high-pass keep
        self.theta = 0.0                     # high-passed gyro angle
        self.acc_hp, self.y_hp = 0.0, 0.0    # high-passed acceleration term and reading
        self._acc_prev = self._y_prev = None
        self._block = [0.0, 0.0, 0.0, 0]     # time, sum of angle + acceleration, sum of readings, readings
        self.u = np.zeros(s.points)          # L_tau of the high-passed angle + acceleration, per grid tau
        self.mean = np.zeros(s.points)       # slow part of the residual (left by the first-order high-passes)
        self.ms = np.zeros(s.points)         # mean square of the residual
        self.seen = 0.0                      # s of readings
        self.tau = None
        self._grid_dt, self._grid_gain = None, None  # a grid step's length and its lag factors (the steps repeat)
        self._tmp = np.empty(s.points)

    def update(self, rate, reading, accel_term, dt):
        if dt <= 0:
            return self.tau
        if dt != self._dt:
            self._dt, self._keep = dt, math.exp(-dt / self.settings.highpass)
        keep = self._keep
        self.theta = theta = keep * self.theta + rate * dt
        if self._acc_prev is not None:
            self.acc_hp = keep * self.acc_hp + (accel_term - self._acc_prev)
        self._acc_prev = accel_term
        block = self._block
        block[0] += dt
        block[1] += (theta + self.acc_hp) * dt
        if reading is not None:
            if self._y_prev is not None:
                self.y_hp = keep * self.y_hp + (reading - self._y_prev)
                block[2] += self.y_hp
                block[3] += 1
            self._y_prev = reading
        if block[0] >= self.settings.step:
            self._grid_step(*block)
            self._block = [0.0, 0.0, 0.0, 0]
        return self.tau

    def _grid_step(self, dt, angle_sum, reading_sum, readings):
        """u += gain (angle mean - u), then the residual's slow mean and mean square; in place (one scratch
        array: the same elementwise operations as the expressions in the comments)."""
        s, u, tmp = self.settings, self.u, self._tmp
        if dt != self._grid_dt:
            self._grid_dt, self._grid_gain = dt, -np.expm1(-dt / self.grid)
        np.subtract(angle_sum / dt, u, out=tmp)
        tmp *= self._grid_gain
        u += tmp                                      # u += gain * (angle_sum / dt - u)
        if not readings:
            return
        r = np.subtract(reading_sum / readings, u)
        np.subtract(r, self.mean, out=tmp)
        tmp *= dt / s.highpass
        self.mean += tmp                              # mean += (dt / highpass) * (r - mean)
        w = dt / s.window if self.seen >= s.window else dt / (self.seen + dt)
        np.subtract(r, self.mean, out=tmp)
        np.multiply(tmp, tmp, out=tmp)
        tmp -= self.ms
        tmp *= w
        self.ms += tmp                                # ms += w * ((r - mean) ** 2 - ms)
        self.seen += dt
        if self.seen >= s.settle:
            self.tau = self._best()

    def _best(self):
        """The grid minimum refined by a parabola in log tau, or None when it does not stand out (or sits on the
        grid's edge)."""
        k = int(np.argmin(self.ms))
        if k < 2 or k > len(self.ms) - 3:
            return None
        ms = self.ms[k - 2:k + 3].tolist()
        lo, mid, hi = ms[1:4]
        if min(ms[0], ms[4]) < self.settings.contrast * mid:
            return None
        curv = lo - 2 * mid + hi
        log_tau, log_below = float(self.log_grid[k]), float(self.log_grid[k - 1])
        offset = 0.5 * (log_tau - log_below) * (lo - hi) / curv if curv > 0 else 0.0
        return math.exp(log_tau + offset)
