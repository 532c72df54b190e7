"""Numbers the kernels share: angle wrapping, small-matrix algebra as loops (no BLAS call for
1x1 to 3x3), the Kalman correction of eq. (10) in Joseph form and the covariance cap.
"""

from __future__ import annotations

import numpy as np

from gyrodrift.kernels import jit

__all__ = ["wrap360", "wrap360_all", "wrap180", "near_boundary", "cap_covariance", "matmul", "matvec", "solve", "correct"]


@jit(inline=True)
def wrap360(x):
    """``x`` (deg) wrapped to [0, 360); an angle already in range is returned as is, and
    one that rounds to 360 after ``mod`` becomes 0 (the range stays half-open). NaN and
    infinities give NaN."""
    if 0.0 <= x < 360.0:
        return x
    out = np.mod(x, 360.0)
    if out >= 360.0:
        out -= 360.0
    return out


@jit
def wrap360_all(x, out):
    """:func:`wrap360` of every element of the 1-d ``x``, into ``out``."""
    for i in range(x.size):
        out[i] = wrap360(x[i])


@jit(inline=True)
def wrap180(x):
    """``x`` (deg) wrapped to [-180, 180)."""
    return wrap360(x + 180.0) - 180.0


@jit
def cap_covariance(P, max_var):
    """A new P limited to at most ``diag(max_var)`` in every direction, symmetric positive definite:
    in coordinates where the cap is the identity, eigenvalues above 1 are clipped to 1 (``docs/engine.md``)."""
    scale = np.sqrt(max_var)
    M = P / np.outer(scale, scale)
    if np.trace(M) <= 1.0:  # P is PSD: no eigenvalue of M can exceed its trace
        return P.copy()
    lam, V = np.linalg.eigh(0.5 * (M + M.T))
    if lam.max() <= 1.0:
        return P.copy()
    clipped = (V * np.minimum(lam, 1.0)) @ V.T * np.outer(scale, scale)
    return 0.5 * (clipped + clipped.T)


@jit(inline=True)
def matmul(A, B):
    """``A @ B`` of small matrices, as plain loops (no BLAS call: the sizes here are 1 to 3;
    the sums go in index order, so the last bit may differ from BLAS)."""
    p, q = A.shape
    r = B.shape[1]
    out = np.empty((p, r))
    for i in range(p):
        for j in range(r):
            acc = A[i, 0] * B[0, j]
            for k in range(1, q):
                acc += A[i, k] * B[k, j]
            out[i, j] = acc
    return out


@jit(inline=True)
def matvec(A, x):
    """``A @ x`` of a small matrix and vector (see :func:`matmul`)."""
    p, q = A.shape
    out = np.empty(p)
    for i in range(p):
        acc = A[i, 0] * x[0]
        for k in range(1, q):
            acc += A[i, k] * x[k]
        out[i] = acc
    return out


@jit
def solve(S, B):
    """``np.linalg.solve(S, B)`` of a small system (S (m, m), B (m, k) or (m,)): LU with
    partial pivoting as LAPACK's ``dgesv``, dividing through reciprocals of the pivots as
    OpenBLAS does (for m = 1, ``B * (1 / S)``)."""
    m = S.shape[0]
    A = S.copy()
    X = B.copy()
    k = X.size // m
    Xv = X.reshape((m, k))
    for c in range(m):
        p = c
        big = abs(A[c, c])
        for r in range(c + 1, m):
            if abs(A[r, c]) > big:
                big = abs(A[r, c])
                p = r
        if p != c:
            for j in range(m):
                A[c, j], A[p, j] = A[p, j], A[c, j]
            for j in range(k):
                Xv[c, j], Xv[p, j] = Xv[p, j], Xv[c, j]
        inv = 1.0 / A[c, c]
        for r in range(c + 1, m):
            f = A[r, c] * inv
            for j in range(c + 1, m):
                A[r, j] -= f * A[c, j]
            for j in range(k):
                Xv[r, j] -= f * Xv[c, j]
    for c in range(m - 1, -1, -1):
        inv = 1.0 / A[c, c]
        for j in range(k):
            acc = Xv[c, j]
            for r in range(c + 1, m):
                acc -= A[c, r] * Xv[r, j]
            Xv[c, j] = acc * inv
    return X


@jit
def correct(x, P, y, H, R):
    """Measurement update of eq. (10) in Joseph form: returns (x⁺, P⁺).

    ``K = P Hᵀ S⁻¹`` with ``S = H P Hᵀ + R``, ``x⁺ = x + K (y − H x)``,
    ``P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ``, symmetrised."""
    n = x.size
    m = y.size
    HP = matmul(H, P)
    S = matmul(HP, H.T) + R
    K = np.ascontiguousarray(solve(S, HP).T)  # P H^T S^-1, as P and S are symmetric
    Hx = matvec(H, x)
    innovation = np.empty(m)
    for r in range(m):
        innovation[r] = y[r] - Hx[r]
    A = -matmul(K, H)
    for i in range(n):
        A[i, i] += 1.0
    P_post = matmul(matmul(A, P), A.T) + matmul(matmul(K, R), K.T)
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.5 * (P_post[i, j] + P_post[j, i])
    Ki = matvec(K, innovation)
    x_post = np.empty(n)
    for i in range(n):
        x_post[i] = x[i] + Ki[i]
    return x_post, out


@jit
def near_boundary(t_start, k_cur, width):
    """A time safely before the start of bin ``k_cur + 1`` of a grid ``t_start + k width``:
    below it ``floor((t - t_start) / width)`` cannot have passed ``k_cur`` (the margin
    covers the rounding of the division), so the division can be skipped."""
    t_next = t_start + (k_cur + 1.0) * width
    return t_next - 1e-9 * (abs(t_next) + abs(t_start) + width)
