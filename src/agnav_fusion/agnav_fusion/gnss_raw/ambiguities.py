"""Bookkeeping of double-difference ambiguity states (metres) when the satellite set or a reference changes.

State keys are (system, slot, satellite j), meaning λ·N^{ref,j} against the current reference of (system, slot).
A new epoch's key set is reached by one linear map of the old ambiguity states: with old reference r and new
reference r', N^{r'j} = N^{rj} − N^{rr'} (N^{rr} = 0), so the mean and the covariance — cross-covariances with
the other states included — carry over exactly (x ← T x, P ← T P Tᵀ). A key whose satellite lost lock, or which
cannot be expressed in old states (satellite rising, old reference gone with no link), starts afresh: zero row
in T, its value and variance supplied by the caller.
"""
import numpy as np


def reindex_matrix(old_keys, old_refs, new_keys, new_refs, reset):
    """(T, fresh): T (len(new_keys), len(old_keys)) maps old ambiguity states to the new ones; fresh (bool per
    new key) marks the keys that T cannot carry over (or that `reset` — a bool per new key — asks to restart)."""
    where = {k: i for i, k in enumerate(old_keys)}
    T = np.zeros((len(new_keys), len(old_keys)))
    fresh = np.zeros(len(new_keys), bool)

    def old_row(system, slot, sat):
        """Row vector expressing λN^{r,sat} (old reference r) in old states; None if not available."""
        row = np.zeros(len(old_keys))
        if old_refs.get((system, slot)) == sat:
            return row
        i = where.get((system, slot, sat))
        if i is None:
            return None
        row[i] = 1.0
        return row

    for n, (system, slot, sat) in enumerate(new_keys):
        if reset[n] or (system, slot) not in old_refs:
            fresh[n] = True
            continue
        a = old_row(system, slot, sat)
        b = old_row(system, slot, new_refs[(system, slot)])
        if a is None or b is None:
            fresh[n] = True
        else:
            T[n] = a - b
    return T, fresh


def reindex(x, P, n_fixed, old_keys, old_refs, new_keys, new_refs, reset, init_value, init_var):
    """State (x, P) with `n_fixed` leading non-ambiguity states and ambiguities `old_keys` -> the same with
    `new_keys`; fresh ambiguities get `init_value`/`init_var` (arrays over new keys) and no correlation."""
    T_amb, fresh = reindex_matrix(old_keys, old_refs, new_keys, new_refs, reset)
    T = np.zeros((n_fixed + len(new_keys), n_fixed + len(old_keys)))
    T[:n_fixed, :n_fixed] = np.eye(n_fixed)
    T[n_fixed:, n_fixed:] = T_amb
    x_new, P_new = T @ x, T @ P @ T.T
    idx = n_fixed + np.flatnonzero(fresh)
    x_new[idx] = np.asarray(init_value)[fresh]
    P_new[idx, :] = 0.0
    P_new[:, idx] = 0.0
    P_new[idx, idx] = np.asarray(init_var)[fresh]
    return x_new, P_new, fresh
