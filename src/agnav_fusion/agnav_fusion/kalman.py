"""Linear(ised) Kalman filter steps, Mahalanobis gate and Rauch-Tung-Striebel smoother (SPEC §8 [IMPL])."""
import numpy as np


def predict(x, P, F, Q):
    """x <- F x, P <- F P F^T + Q."""
    return F @ x, F @ P @ F.T + Q


def innovation(x, P, z, H, R, h=None):
    """Innovation y, its covariance S and squared Mahalanobis distance y^T S^-1 y."""
    y = z - (H @ x if h is None else h)
    S = H @ P @ H.T + R
    return y, S, float(y @ np.linalg.solve(S, y))


def update(x, P, y, S, H, R):
    """Joseph-form update with a precomputed innovation (y, S)."""
    K = np.linalg.solve(S, H @ P).T
    IKH = np.eye(len(x)) - K @ H
    return x + K @ y, IKH @ P @ IKH.T + K @ R @ K.T


def update_state(x, P, i, z, r, gate=None):
    """Measurement z (variance r) of the single state x[i]: the same update as innovation + update for H = e_i,
    without the small-matrix overhead (the per-sample path). Returns (x, P, d2); refused (x, P unchanged) when
    d2 exceeds `gate`."""
    Pi = P[:, i]
    S = Pi[i] + r
    y = z - x[i]
    d2 = y * y / S
    if gate is not None and d2 > gate:
        return x, P, d2
    K = Pi / S
    P = P - np.outer(K, Pi)
    return x + K * y, (P + P.T) * 0.5, d2


def rts(xs_f, Ps_f, xs_p, Ps_p, Fs, angles=()):
    """RTS smoother: filtered (x_k|k, P_k|k), predicted (x_k+1|k, P_k+1|k) and F_k (x_k+1 = F_k x_k);
    state indices in `angles` are differenced on the circle."""
    xs, Ps = [xs_f[-1]], [Ps_f[-1]]
    for k in range(len(xs_f) - 2, -1, -1):
        C = Ps_f[k] @ Fs[k].T @ np.linalg.pinv(Ps_p[k], hermitian=True)  # pinv: states held fixed have P = 0
        dx = xs[-1] - xs_p[k]
        for i in angles:
            dx[i] = np.remainder(dx[i] + np.pi, 2 * np.pi) - np.pi
        xs.append(xs_f[k] + C @ dx)
        Ps.append(Ps_f[k] + C @ (Ps[-1] - Ps_p[k]) @ C.T)
    return np.array(xs[::-1]), np.array(Ps[::-1])


def smooth_log(log, angles=()):
    """RTS over a filter log of (F_k, x_k|k-1, P_k|k-1, x_k|k, P_k|k) entries; returns smoothed (xs, Ps)."""
    F, xp, Pp, xf, Pf = (list(v) for v in zip(*log))
    return rts(xf, Pf, xp[1:], Pp[1:], F[1:], angles)


def mahalanobis2(S, y):
    """y^T S^-1 y (= y @ np.linalg.solve(S, y)); up to 3x3 by the adjugate on Python floats (a positive
    determinant; anything else goes to np.linalg.solve, which raises on a singular S as before)."""
    n = len(y)
    if n <= 3:
        y = y.tolist()
        if n == 1:
            s = float(S[0, 0])
            if s > 0.0:
                return y[0] * y[0] / s
        elif n == 2:
            (a, b), (c, d) = S.tolist()
            det = a * d - b * c
            if det > 0.0:
                return (y[0] * (d * y[0] - b * y[1]) + y[1] * (a * y[1] - c * y[0])) / det
        else:
            (a, b, c), (d, e, f), (g, h, i) = S.tolist()
            A, B, C = e * i - f * h, f * g - d * i, d * h - e * g          # first column of the adjugate
            det = a * A + b * B + c * C
            if det > 0.0:
                y0, y1, y2 = y
                x0 = A * y0 + (c * h - b * i) * y1 + (b * f - c * e) * y2
                x1 = B * y0 + (a * i - c * g) * y1 + (c * d - a * f) * y2
                x2 = C * y0 + (b * g - a * h) * y1 + (a * e - b * d) * y2
                return (y0 * x0 + y1 * x1 + y2 * x2) / det
    return float(y @ np.linalg.solve(S, y))
