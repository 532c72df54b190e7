"""Numbers the kernels share: angle wrapping, sums, small-matrix algebra, the Kalman
correction and the covariance cap.

* :func:`wrap360`, :func:`wrap180`: angles to [0, 360) and [-180, 180) (the scalar forms
  of :func:`gyrodrift.conventions.wrap_360` and ``wrap_180``).
* :func:`pairwise_sum`, :func:`pairwise_sqdev`, :func:`std_of`: sums in numpy's pairwise
  order (window means and standard deviations of the aiding tests).
* :func:`matmul`, :func:`matmul_t`, :func:`matvec`, :func:`solve`: products and solves of
  the 1x1 to 3x3 matrices of the filters, as loops (no BLAS call for such sizes).
* :func:`correct`: the measurement update of eq. (10) in Joseph form;
  :func:`cap_covariance`: the bound on the covariance (see :mod:`gyrodrift.kernels.kalman`).
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.kernels import jit

__all__ = ["wrap360", "wrap180", "near_boundary", "pairwise_sum", "pairwise_sqdev", "std_of", "sym_eig", "cap_covariance",
           "matmul", "matmul_t", "matvec", "solve", "correct"]

# numpy's block size of the pairwise summation
_PW_BLOCKSIZE = 128


@jit(inline=True)
def wrap360(x):
    """``x`` (deg) wrapped to [0, 360); an angle already in range is returned as is."""
    if 0.0 <= x < 360.0:
        return x
    out = np.mod(x, 360.0)
    if out >= 360.0:
        out -= 360.0
    return out


@jit(inline=True)
def wrap180(x):
    """``x`` (deg) wrapped to [-180, 180)."""
    return wrap360(x + 180.0) - 180.0


@jit(inline=True)
def _block_sum(a, lo, n):
    """numpy's sum of at most 128 numbers (``pairwise_sum`` without the split)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    stop = n - (n % 8)
    while i < stop:
        j = lo + i
        r0 += a[j]
        r1 += a[j + 1]
        r2 += a[j + 2]
        r3 += a[j + 3]
        r4 += a[j + 4]
        r5 += a[j + 5]
        r6 += a[j + 6]
        r7 += a[j + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@jit(inline=True)
def pairwise_sum(a, lo, n):
    """Sum of ``a[lo:lo + n]`` in the order of numpy's ``np.add.reduce`` on a float64 array.

    numpy adds fewer than 8 numbers one after the other; up to 128 in 8 interleaved
    partial sums; more by halves (split at a multiple of 8), recursively. ``np.sum(x)``
    and ``np.mean(x) * n`` of the same numbers then have the same bits (``np.mean``
    divides this sum by n), and so does each row of ``x.reshape(-1, m).mean(axis=1)``.
    The recursion is unrolled on an explicit stack (numba cannot cache a recursive
    function).
    """
    if n <= _PW_BLOCKSIZE:
        return _block_sum(a, lo, n)
    return _pairwise_tree(a, lo, n)


@jit
def _pairwise_tree(a, lo, n):
    """:func:`pairwise_sum` of more than 128 numbers (out of line: the callers inline the rest)."""
    # post-order walk of the halving tree: (lo, n, combine?) to do, partial sums done
    todo = np.empty((128, 3), dtype=np.int64)
    done = np.empty(128)
    n_todo = 1
    n_done = 0
    todo[0, 0], todo[0, 1], todo[0, 2] = lo, n, 0
    while n_todo > 0:
        n_todo -= 1
        lo_, n_, combine = todo[n_todo, 0], todo[n_todo, 1], todo[n_todo, 2]
        if combine == 1:  # left + right, as numpy returns them
            n_done -= 1
            done[n_done - 1] = done[n_done - 1] + done[n_done]
        elif n_ <= _PW_BLOCKSIZE:
            done[n_done] = _block_sum(a, lo_, n_)
            n_done += 1
        else:
            n2 = n_ // 2
            n2 -= n2 % 8
            todo[n_todo, 0], todo[n_todo, 1], todo[n_todo, 2] = lo_, n_, 1
            todo[n_todo + 1, 0], todo[n_todo + 1, 1], todo[n_todo + 1, 2] = lo_ + n2, n_ - n2, 0
            todo[n_todo + 2, 0], todo[n_todo + 2, 1], todo[n_todo + 2, 2] = lo_, n2, 0
            n_todo += 3
    return done[0]


@jit(inline=True)
def _block_sqdev(a, lo, n, mu):
    """:func:`_block_sum` of ``(a - mu)²`` (each term as numpy's ``d = a - mu; d * d``)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            d = a[lo + i] - mu
            res += d * d
        return res
    d0, d1, d2, d3 = a[lo] - mu, a[lo + 1] - mu, a[lo + 2] - mu, a[lo + 3] - mu
    d4, d5, d6, d7 = a[lo + 4] - mu, a[lo + 5] - mu, a[lo + 6] - mu, a[lo + 7] - mu
    r0, r1, r2, r3, r4, r5, r6, r7 = d0 * d0, d1 * d1, d2 * d2, d3 * d3, d4 * d4, d5 * d5, d6 * d6, d7 * d7
    i = 8
    stop = n - (n % 8)
    while i < stop:
        j = lo + i
        d0, d1, d2, d3 = a[j] - mu, a[j + 1] - mu, a[j + 2] - mu, a[j + 3] - mu
        d4, d5, d6, d7 = a[j + 4] - mu, a[j + 5] - mu, a[j + 6] - mu, a[j + 7] - mu
        r0 += d0 * d0
        r1 += d1 * d1
        r2 += d2 * d2
        r3 += d3 * d3
        r4 += d4 * d4
        r5 += d5 * d5
        r6 += d6 * d6
        r7 += d7 * d7
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        d = a[lo + i] - mu
        res += d * d
        i += 1
    return res


@jit(inline=True)
def pairwise_sqdev(a, lo, n, mu):
    """Sum of ``(a[lo:lo + n] - mu)²`` in numpy's order (:func:`pairwise_sum` of the squares,
    without making the array of them)."""
    if n <= _PW_BLOCKSIZE:
        return _block_sqdev(a, lo, n, mu)
    return _sqdev_tree(a, lo, n, mu)


@jit
def _sqdev_tree(a, lo, n, mu):
    """:func:`pairwise_sqdev` of more than 128 numbers."""
    todo = np.empty((128, 3), dtype=np.int64)
    done = np.empty(128)
    n_todo = 1
    n_done = 0
    todo[0, 0], todo[0, 1], todo[0, 2] = lo, n, 0
    while n_todo > 0:
        n_todo -= 1
        lo_, n_, combine = todo[n_todo, 0], todo[n_todo, 1], todo[n_todo, 2]
        if combine == 1:
            n_done -= 1
            done[n_done - 1] = done[n_done - 1] + done[n_done]
        elif n_ <= _PW_BLOCKSIZE:
            done[n_done] = _block_sqdev(a, lo_, n_, mu)
            n_done += 1
        else:
            n2 = n_ // 2
            n2 -= n2 % 8
            todo[n_todo, 0], todo[n_todo, 1], todo[n_todo, 2] = lo_, n_, 1
            todo[n_todo + 1, 0], todo[n_todo + 1, 1], todo[n_todo + 1, 2] = lo_ + n2, n_ - n2, 0
            todo[n_todo + 2, 0], todo[n_todo + 2, 1], todo[n_todo + 2, 2] = lo_, n2, 0
            n_todo += 3
    return done[0]


@jit
def std_of(a, lo, n):
    """``np.std`` of ``a[lo:lo + n]`` (population, ddof 0), the same bits, read in place."""
    mu = pairwise_sum(a, lo, n) / n
    return np.sqrt(pairwise_sqdev(a, lo, n, mu) / n)


@jit
def sym_eig(A):
    """Eigenvalues and eigenvectors (columns) of a small symmetric matrix: cyclic Jacobi
    rotations until the off-diagonal part is below rounding (``np.linalg.eigh`` to the
    last bits, unsorted; for the 3×3 of :func:`cap_covariance` about 5 times faster than
    the LAPACK call)."""
    n = A.shape[0]
    a = A.copy()
    V = np.eye(n)
    for _ in range(64):
        off = 0.0
        diag = 0.0
        for p in range(n):
            diag += a[p, p] * a[p, p]
            for q in range(p + 1, n):
                off += a[p, q] * a[p, q]
        if off <= 1e-36 * diag:  # |off-diagonal| below 1e-18 of the norm: done
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                apq = a[p, q]
                if apq == 0.0:
                    continue
                theta = (a[q, q] - a[p, p]) / (2.0 * apq)
                if abs(theta) > 1e150:
                    t = 0.5 / theta
                else:
                    t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                    if theta < 0.0:
                        t = -t
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):  # A <- A J
                    akp = a[k, p]
                    akq = a[k, q]
                    a[k, p] = c * akp - s * akq
                    a[k, q] = s * akp + c * akq
                for k in range(n):  # A <- J^T A
                    apk = a[p, k]
                    aqk = a[q, k]
                    a[p, k] = c * apk - s * aqk
                    a[q, k] = s * apk + c * aqk
                a[p, q] = 0.0
                a[q, p] = 0.0
                for k in range(n):  # V <- V J
                    vkp = V[k, p]
                    vkq = V[k, q]
                    V[k, p] = c * vkp - s * vkq
                    V[k, q] = s * vkp + c * vkq
    lam = np.empty(n)
    for p in range(n):
        lam[p] = a[p, p]
    return lam, V


@jit
def cap_covariance(P, max_var):
    """P limited to at most ``diag(max_var)`` in every direction (``P <= P_max``).

    In coordinates where ``P_max`` is the identity, eigenvalues of P above 1 are clipped
    to 1; directions already known better than the cap keep their variance (clipping each
    variance on its own would not: with a and c strongly correlated it would inflate the
    variance of the well-known combination ``a*T + c``). P stays symmetric positive
    definite. Returns a new matrix.
    """
    n = P.shape[0]
    scale = np.sqrt(max_var)
    M = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            M[i, j] = P[i, j] / (scale[i] * scale[j])
    tr = 0.0
    for i in range(n):
        tr += M[i, i]
    if tr <= 1.0:  # P is PSD: no eigenvalue of M can exceed its trace
        return P.copy()
    Ms = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            Ms[i, j] = 0.5 * (M[i, j] + M[j, i])
    lam, V = sym_eig(Ms)
    top = lam[0]
    for k in range(1, n):
        top = max(top, lam[k])
    if top <= 1.0:
        return P.copy()
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            acc = (V[i, 0] * min(lam[0], 1.0)) * V[j, 0]
            for k in range(1, n):
                acc += (V[i, k] * min(lam[k], 1.0)) * V[j, k]
            out[i, j] = acc * (scale[i] * scale[j])
    sym = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            sym[i, j] = 0.5 * (out[i, j] + out[j, i])
    return sym


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
def matmul_t(A, B):
    """``A @ B.T`` of small matrices (see :func:`matmul`)."""
    p, q = A.shape
    r = B.shape[0]
    out = np.empty((p, r))
    for i in range(p):
        for j in range(r):
            acc = A[i, 0] * B[j, 0]
            for k in range(1, q):
                acc += A[i, k] * B[j, k]
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
    S = matmul_t(HP, H) + R
    K = np.ascontiguousarray(solve(S, HP).T)  # P H^T S^-1, as P and S are symmetric
    Hx = matvec(H, x)
    innovation = np.empty(m)
    for r in range(m):
        innovation[r] = y[r] - Hx[r]
    A = -matmul(K, H)
    for i in range(n):
        A[i, i] += 1.0
    P_post = matmul_t(matmul(A, P), A) + matmul_t(matmul(K, R), K)
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
