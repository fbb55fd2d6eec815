"""The compiled loops behind the thin plate spline (:mod:`.tps`): distances, rank, the choice.

Each is in numba's nopython subset and compiled by :func:`hila_lang.core.jit.compiled` (the
callers in :mod:`.tps` ask for them: ``_dist_compiled``, ``_rank_compiled``, ``_kernel``); each
has a numpy twin in :mod:`.tps` that computes the same values (tested:
tests/test_core_osila.py, tests/test_core_osila_kernels.py).  Kept apart from :mod:`.tps` so that
module reads as the warp and its choice, not as loops.
"""

from __future__ import annotations

import numpy as np

#: the compiled choice's 3-D similarity refits take their rotation by Newton's polar iteration where
#: det covk > POLAR_TOL |covk|_F³ (smallest singular value well above rounding: the polar factor
#: is Umeyama's rotation, no reflection to fix), else by the SVD; at most POLAR_STEPS steps
#: (scaled Newton converges in under 10 for condition numbers up to 1e16), else the SVD
POLAR_TOL = 1e-9
POLAR_STEPS = 30


def _dist_kernel(a, b, out):  # pragma: no cover - compiled by numba (hila_lang.core.jit)
    """:func:`_dist_numpy` as loops into ``out`` (N, M): the same sums in the same order, a row of
    ``out`` per coordinate (the loops over M vectorise: 1.6-2.6x faster than a loop over the
    coordinates inside, at T x K = 1000 x 10 to 10000 x 1000 here)."""
    N, D = a.shape
    M = b.shape[0]
    bT = np.ascontiguousarray(b.T)
    for i in range(N):
        row = out[i]
        ai = a[i, 0]
        bk = bT[0]
        for j in range(M):
            d = ai - bk[j]
            row[j] = d * d
        for k in range(1, D):
            ai = a[i, k]
            bk = bT[k]
            for j in range(M):
                d = ai - bk[j]
                row[j] = row[j] + d * d
        for j in range(M):
            row[j] = np.sqrt(row[j])


def _rank_kernel(src, tol):  # pragma: no cover - compiled by numba (hila_lang.core.jit)
    """:func:`_affine_rank` as loops: the covariance of the centred points, its eigenvalues by
    cyclic Jacobi rotations to rounding (off-diagonal below 1e-17 of the largest diagonal
    entry), the count of square roots above ``tol ×`` the largest."""
    K, D = src.shape
    mu = np.zeros(D)
    for i in range(K):
        for d in range(D):
            mu[d] += src[i, d]
    C = np.zeros((D, D))
    for i in range(K):
        for r in range(D):
            ar = src[i, r] - mu[r] / K
            for c in range(D):
                C[r, c] += ar * (src[i, c] - mu[c] / K)
    scale = 0.0
    for r in range(D):
        scale = max(scale, abs(C[r, r]))
    if scale <= 0.0:
        return 0
    for _ in range(60):
        off = 0.0
        for p in range(D - 1):
            for q in range(p + 1, D):
                off = max(off, abs(C[p, q]))
        if off <= 1e-17 * scale:
            break
        for p in range(D - 1):
            for q in range(p + 1, D):
                if C[p, q] == 0.0:
                    continue
                theta = (C[q, q] - C[p, p]) / (2.0 * C[p, q])
                t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                for k in range(D):  # C <- C J, then Jᵀ C (J: the rotation in the (p, q) plane)
                    ckp, ckq = C[k, p], C[k, q]
                    C[k, p] = c * ckp - s * ckq
                    C[k, q] = s * ckp + c * ckq
                for k in range(D):
                    cpk, cqk = C[p, k], C[q, k]
                    C[p, k] = c * cpk - s * cqk
                    C[q, k] = s * cpk + c * cqk
                C[p, q] = 0.0
                C[q, p] = 0.0
    top = 0.0
    for r in range(D):
        top = max(top, np.sqrt(max(C[r, r], 0.0)))
    if top <= 0.0:
        return 0
    n = 0
    for r in range(D):
        if np.sqrt(max(C[r, r], 0.0)) > tol * top:
            n += 1
    return n


def _choice_kernel(src, dst, ridge, card, lin, w, loo):  # pragma: no cover - compiled by numba (hila_lang.core.jit)
    """The systems behind :func:`fit_warp`'s choice, as loops (numpy twin: :func:`_choice_numpy`).

    Fills ``card`` (K + D + 1, K) with A⁻¹[:, :K] of the TPS system on the normalised template
    points, ``lin`` (D + 1, D) and ``w`` (K, D) with the similarity fallback on all pairs, and
    ``loo`` (K,) with the fallback's leave-one-out squared error per pair, by Rippa's closed form
    on one inverse of the fallback's interpolation system (:func:`_similarity_loo`); the inverses
    by Gauss-Jordan elimination, the 3-D refits' rotations by Newton's polar iteration.  Needs
    K >= D + 2 points spanning D dimensions.
    """
    K, D = src.shape
    mu = np.zeros(D)
    for i in range(K):
        mu += src[i]
    mu /= K
    sc = 0.0
    for i in range(K):
        for d in range(D):
            sc = max(sc, abs(src[i, d] - mu[d]))
    # --- the TPS system: [[U(|x_i - x_j|) + ridge, 1, x], [1, 0, 0], [xᵀ, 0, 0]]
    n = K + D + 1
    A = np.zeros((n, n))
    for i in range(K):
        for j in range(K):
            r2 = 0.0
            for d in range(D):
                diff = (src[i, d] - mu[d]) / sc - (src[j, d] - mu[d]) / sc
                r2 += diff * diff
            r = np.sqrt(r2)
            if D == 2:
                A[i, j] = r * r * np.log(r) if r > 0 else 0.0
            else:
                A[i, j] = r
        A[i, i] += ridge[i]
        A[i, K] = 1.0
        A[K, i] = 1.0
        for d in range(D):
            A[i, K + 1 + d] = (src[i, d] - mu[d]) / sc
            A[K + 1 + d, i] = A[i, K + 1 + d]
    # --- the fallback's interpolation system [[φ(|s_i - s_j| / sc), 1], [1, 0]], without ridge
    B = np.zeros((K + 1, K + 1))
    for i in range(K):
        for j in range(K):
            r2 = 0.0
            for d in range(D):
                diff = src[i, d] - src[j, d]
                r2 += diff * diff
            B[i, j] = np.sqrt(r2) / sc
        B[i, K] = 1.0
        B[K, i] = 1.0
    # --- both inverses by Gauss-Jordan elimination with partial pivoting, in loops (LAPACK's LU
    # inverse through numba cost ~15 us of the first call at K = 10, its code and buffers cold;
    # the same inverse to rounding, tested against the numpy twin's Cholesky); singular: raise
    Ainv = np.eye(n)
    Binv = np.eye(K + 1)
    for which in range(2):
        M = A.copy() if which == 0 else B.copy()
        Inv = Ainv if which == 0 else Binv
        m = M.shape[0]
        for col in range(m):
            p = col
            best = abs(M[col, col])
            for r in range(col + 1, m):
                if abs(M[r, col]) > best:
                    best = abs(M[r, col])
                    p = r
            if best == 0.0:
                raise ZeroDivisionError("singular system")
            if p != col:
                for c in range(m):
                    t = M[col, c]
                    M[col, c] = M[p, c]
                    M[p, c] = t
                    t = Inv[col, c]
                    Inv[col, c] = Inv[p, c]
                    Inv[p, c] = t
            piv = M[col, col]
            for c in range(m):
                M[col, c] /= piv
                Inv[col, c] /= piv
            for r in range(m):
                f = M[r, col]
                if r != col and f != 0.0:
                    for c in range(col, m):
                        M[r, c] -= f * M[col, c]
                    for c in range(m):
                        Inv[r, c] -= f * Inv[col, c]
    for i in range(n):
        for j in range(K):
            card[i, j] = Ainv[i, j]
    # centred pairs (the similarity is fitted on centred points; G 1 = 0 drops the constants)
    ms = np.zeros(D)
    md = np.zeros(D)
    for i in range(K):
        ms += src[i]
        md += dst[i]
    ms /= K
    md /= K
    a = np.empty((K, D))
    b = np.empty((K, D))
    for i in range(K):
        for d in range(D):
            a[i, d] = src[i, d] - ms[d]
            b[i, d] = dst[i, d] - md[d]
    # totals of the similarity's normal equations: Σ b aᵀ and Σ |a|²
    cov = np.zeros((D, D))
    var = 0.0
    for i in range(K):
        for r in range(D):
            var += a[i, r] * a[i, r]
            for c in range(D):
                cov[r, c] += b[i, r] * a[i, c]
    # --- the similarity on all pairs (k = -1) and without each pair k, from the totals; then the
    # exact interpolation of the residuals (k = -1), or Rippa's closed form on G = (B⁻¹)[:K, :K]
    Ga = np.zeros((K, D))
    Gb = np.zeros((K, D))
    for i in range(K):
        for j in range(K):
            g = Binv[i, j]
            for d in range(D):
                Ga[i, d] += g * a[j, d]
                Gb[i, d] += g * b[j, d]
    m = K - 1.0
    covk = np.empty((D, D))
    for k in range(-1, K):
        var_k = var
        for r in range(D):
            for c in range(D):
                covk[r, c] = cov[r, c]
        if k >= 0:  # the other pairs' centroid offsets and normal equations
            for r in range(D):
                var_k -= a[k, r] * a[k, r] + a[k, r] * a[k, r] / m
                for c in range(D):
                    covk[r, c] -= b[k, r] * a[k, c] + b[k, r] * a[k, c] / m
        sR = np.zeros((D, D))  # scale * R
        if D == 2:
            re = (covk[0, 0] + covk[1, 1]) / var_k
            im = (covk[1, 0] - covk[0, 1]) / var_k
            sR[0, 0], sR[0, 1], sR[1, 0], sR[1, 1] = re, -im, im, re
        else:
            # Umeyama's rotation U diag(1, 1, sign det) Vᵀ is the polar factor of covk when
            # det covk > 0 (then S.sum() = trace(Rᵀ covk)): Higham's scaled Newton iteration
            # X <- (g X + X⁻ᵀ / g) / 2 on 3 x 3 cofactors, to rounding in 5-9 steps, instead of
            # a LAPACK SVD and determinant (~3 us each left-out pair); a reflection or a nearly
            # singular covk (det <= POLAR_TOL |covk|³) keeps the SVD
            nrm = 0.0
            for r in range(3):
                for c in range(3):
                    nrm += covk[r, c] * covk[r, c]
            nrm = np.sqrt(nrm)
            det = (covk[0, 0] * (covk[1, 1] * covk[2, 2] - covk[1, 2] * covk[2, 1])
                   - covk[0, 1] * (covk[1, 0] * covk[2, 2] - covk[1, 2] * covk[2, 0])
                   + covk[0, 2] * (covk[1, 0] * covk[2, 1] - covk[1, 1] * covk[2, 0]))
            done = False
            if det > POLAR_TOL * nrm * nrm * nrm:
                X = covk / nrm
                cof = np.empty((3, 3))
                for _ in range(POLAR_STEPS):
                    for r in range(3):
                        r1, r2 = (r + 1) % 3, (r + 2) % 3
                        for c in range(3):
                            c1, c2 = (c + 1) % 3, (c + 2) % 3
                            cof[r, c] = X[r1, c1] * X[r2, c2] - X[r1, c2] * X[r2, c1]
                    dx = X[0, 0] * cof[0, 0] + X[0, 1] * cof[0, 1] + X[0, 2] * cof[0, 2]
                    nx = 0.0
                    nc = 0.0
                    for r in range(3):
                        for c in range(3):
                            nx += X[r, c] * X[r, c]
                            nc += cof[r, c] * cof[r, c]
                    g = np.sqrt(np.sqrt(nc) / abs(dx) / np.sqrt(nx))  # |X⁻¹| / |X|, X⁻ᵀ = cof / det
                    step = 0.0
                    for r in range(3):
                        for c in range(3):
                            new = 0.5 * (g * X[r, c] + cof[r, c] / (g * dx))
                            step = max(step, abs(new - X[r, c]))
                            X[r, c] = new
                    if step <= 1e-15:
                        done = True
                        break
            if done:
                tr = 0.0
                for r in range(3):
                    for c in range(3):
                        tr += X[r, c] * covk[r, c]
                for r in range(3):
                    for c in range(3):
                        sR[r, c] = (tr / var_k) * X[r, c]
            else:
                U, S, Vt = np.linalg.svd(covk)
                if np.linalg.det(U @ Vt) < 0:
                    U[:, D - 1] *= -1.0
                    S[D - 1] *= -1.0
                sR = (S.sum() / var_k) * (U @ Vt)
        if k >= 0:
            loo[k] = 0.0
            for d in range(D):
                e = Gb[k, d]
                for c in range(D):
                    e -= sR[d, c] * Ga[k, c]
                e /= Binv[k, k]
                loo[k] += e * e
            continue
        R = np.zeros((K + 1, D))
        for i in range(K):
            for d in range(D):
                pred = 0.0
                for c in range(D):
                    pred += sR[d, c] * a[i, c]
                R[i, d] = b[i, d] - pred
        ridged = False
        for i in range(K):
            if ridge[i] != 0.0:
                ridged = True
        if ridged:
            Br = B.copy()
            for i in range(K):
                Br[i, i] += ridge[i]
            sol = np.linalg.solve(Br, R)
        else:
            sol = np.zeros((K + 1, D))
            for i in range(K + 1):
                for j in range(K + 1):
                    g = Binv[i, j]
                    for d in range(D):
                        sol[i, d] += g * R[j, d]
        for d in range(D):
            shift = md[d] + sol[K, d]
            for c in range(D):
                shift -= sR[d, c] * ms[c]
                lin[1 + c, d] = sR[d, c]
            lin[0, d] = shift
        for i in range(K):
            for d in range(D):
                w[i, d] = sol[i, d]
