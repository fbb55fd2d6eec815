"""The warp's interpolation systems held as one Cholesky factor: Rippa's errors without full inverses.

The warp's choice (:mod:`.tps`) judges the TPS and the similarity fallback by their leave-one-out
errors, e_k = (A⁻¹f)_k / (A⁻¹)_kk (Rippa).  Of each inverse it needs only the diagonal and one
product A⁻¹f -- the whole inverse only where the TPS wins (the amplification check forms its
cardinal functions) or plan adjustment borders it.  So a system A = [[phi, P], [Pᵀ, 0]] is kept
as the Cholesky factor L of its kernel matrix projected onto the null space of Pᵀ:

    Z = the last columns of Q (P = Q R, Householder),   sign · Zᵀ phi Z = L Lᵀ,
    G = (A⁻¹)[:K, :K] = sign · Z (L Lᵀ)⁻¹ Zᵀ = sign · F Fᵀ   with   F = Z L⁻ᵀ,

whence diag(G)_i = sign · |F_i|² and G f = sign · F (Fᵀ f): one factorisation (K³/3 flops) and
one triangular inverse (K³/3), against a factorisation and a full inverse (K³) per system before.
The last rows of A⁻¹ (the polynomial part) follow from G: Eᵀ = R⁻¹ Q₁ᵀ (I - phi G).

In 3-D both systems have the same kernel (φ(r) = r on the same normalised distances) and the
fallback's polynomial part (a constant) is the first column of the TPS's ([1, x]).  With the
Householder QR of [1, x], the fallback's null space is spanned by Q's columns 1..K-1 and the
TPS's by its columns D+1..K-1; ordering the former as (D+1..K-1, 1..D), the TPS's projected
matrix is the LEADING block of the fallback's, so one Cholesky factor of size K - 1, and one
triangular inverse, serve both systems (the TPS's factor is its leading block).  In 2-D the
kernels differ (r² log r and r): a factor each.

Q is applied in the compact WY form Q = I - V T Vᵀ (a few rank-(D+1) products, one pass over a
K × K matrix each) instead of one reflector at a time.  The same inverse as
:func:`_saddle_inverse` (below) to rounding (tested); None where a factorisation fails (a kernel
matrix that is not definite to rounding), and the caller takes the general inverses.
"""

from __future__ import annotations

import numpy as np

#: factorisations made (one per Cholesky factor; counted by the tests of plan adjustment)
FACTORISATIONS = [0]


class Householder:
    """Q of the QR of ``P`` (K, q) in compact WY form, Q = I - V T Vᵀ, and R (q, q)."""

    def __init__(self, P: np.ndarray):
        K, q = P.shape
        h, tau = np.linalg.qr(P, mode="raw")
        h = h.T  # (K, q): R on and above the diagonal, the reflectors below (unit diagonal implied)
        V = np.tril(h, -1)
        V[np.arange(q), np.arange(q)] = 1.0
        T = np.zeros((q, q))
        for j in range(q):
            T[j, j] = tau[j]
            if j:
                T[:j, j] = -tau[j] * (T[:j, :j] @ (V[:, :j].T @ V[:, j]))
        self.V, self.T, self.R = V, T, np.triu(h[:q, :q])

    def apply(self, X: np.ndarray, transpose: bool = False) -> np.ndarray:
        """Q X (or Qᵀ X), X (K, n)."""
        T = self.T.T if transpose else self.T
        return X - self.V @ (T @ (self.V.T @ X))

    def two_sided(self, X: np.ndarray, transpose: bool = False) -> np.ndarray:
        """Qᵀ X Q for symmetric X (or Q X Qᵀ with ``transpose``), as one rank-2q update of X."""
        V, T = self.V, (self.T.T if transpose else self.T)
        W = X @ V
        Y = W @ T
        C = T.T @ (V.T @ W) @ T
        return X - np.hstack([Y, V]) @ np.vstack([V.T, Y.T - C @ V.T])


class Saddle:
    """The inverse of A = [[phi, P], [Pᵀ, 0]] held as a factor (module docstring); P = the first
    ``q`` columns of the Householder QR ``house``, its null-space basis Q's columns ``blocks``
    (pairs (start, stop) in factor order), ``Linv`` = L⁻¹ of that order, ``sign`` ±1."""

    def __init__(self, phi, house: Householder, q: int, blocks, Linv: np.ndarray, sign: float):
        self.phi, self.house, self.q, self.blocks, self.Linv, self.sign = phi, house, q, blocks, Linv, sign
        self._F = self._diag = self._full = None
        self._last = (None, None)  # (key of f, A⁻¹[:, :K] f): the screen and the warp ask in turn

    def _embed(self, X: np.ndarray, cols: bool) -> np.ndarray:
        """Rows (and with ``cols`` columns) of factor order ``X`` placed at Q's columns ``blocks``."""
        K = len(self.phi)
        out = np.zeros((K, K if cols else X.shape[1]))
        a = 0
        for start, stop in self.blocks:
            if not cols:
                out[start:stop] = X[a:a + stop - start]
            else:
                b = 0
                for s2, e2 in self.blocks:
                    out[start:stop, s2:e2] = X[a:a + stop - start, b:b + e2 - s2]
                    b += e2 - s2
            a += stop - start
        return out

    @property
    def F(self) -> np.ndarray:
        """F = Z L⁻ᵀ (K, n)."""
        if self._F is None:
            self._F = self.house.apply(self._embed(self.Linv.T, False))
        return self._F

    def diagonal(self) -> np.ndarray:
        """diag(G) (K,)."""
        if self._diag is None:
            F = self.F
            self._diag = self.sign * np.einsum("ij,ij->i", F, F)
        return self._diag

    def gram(self, f: np.ndarray) -> np.ndarray:
        """G f, shape (K, D), for f (K, D)."""
        return self.sign * (self.F @ (self.F.T @ f))

    def solve(self, f: np.ndarray) -> np.ndarray:
        """A⁻¹[:, :K] f, shape (K + q, D), for f (K, D); the last one remembered (a copy returned)."""
        key = (f.tobytes(), f.shape)
        if self._last[0] != key:
            Gf = self.gram(f)
            self._last = (key, np.vstack([Gf, self._poly_rows(f - self.phi @ Gf)]))
        return self._last[1].copy()

    def _poly_rows(self, X: np.ndarray) -> np.ndarray:
        """R⁻¹ Q₁ᵀ X: the polynomial rows of A⁻¹ applied (X = (I - phi G) f)."""
        q = self.q
        Q1tX = self.house.apply(X, transpose=True)[:q]
        return np.linalg.solve(self.house.R[:q, :q], Q1tX)

    def full(self) -> np.ndarray:
        """A⁻¹[:, :K], shape (K + q, K) (what :func:`_inverse` gives), made once."""
        if self._full is None:
            # lazy: loads scipy, which importing this module does not
            from scipy.linalg import lapack

            Minv, info = lapack.dlauum(self.Linv, lower=1)  # L⁻ᵀ L⁻¹ = (L Lᵀ)⁻¹, lower triangle
            if info != 0:
                raise np.linalg.LinAlgError("dlauum failed")
            Minv = np.tril(Minv)
            Minv += np.tril(Minv, -1).T
            G = self.house.two_sided(self.sign * self._embed(Minv, True), transpose=True)  # Q B Qᵀ
            G = 0.5 * (G + G.T)
            K = len(G)
            out = np.empty((K + self.q, K))
            out[:K] = G
            Q1t = self.house.apply(np.eye(K, self.q)).T  # Q₁ᵀ (q, K)
            out[K:] = np.linalg.solve(self.house.R[:self.q, :self.q], Q1t - (Q1t @ self.phi) @ G)
            self._full = out
        return self._full


def _factor(M: np.ndarray) -> np.ndarray | None:
    """L⁻¹ of the Cholesky factor of the symmetric positive definite ``M`` (C order, overwritten),
    or None when it is not definite to rounding."""
    # lazy: loads scipy, which importing this module does not
    from scipy.linalg import lapack

    FACTORISATIONS[0] += 1
    L, info = lapack.dpotrf(M.T, lower=1, clean=1, overwrite_a=1)  # M.T: Fortran order, no copy
    if info != 0:
        return None
    Linv, info = lapack.dtrtri(L, lower=1, overwrite_c=1)
    return None if info != 0 else Linv


def _projected(X: np.ndarray, blocks, sign: float) -> np.ndarray:
    """sign · X[cols][:, cols] for the columns ``blocks`` (factor order), by block copies."""
    n = sum(b - a for a, b in blocks)
    M = np.empty((n, n))
    r = 0
    for a, b in blocks:
        c = 0
        for a2, b2 in blocks:
            M[r:r + b - a, c:c + b2 - a2] = X[a:b, a2:b2]
            c += b2 - a2
        r += b - a
    if sign < 0:
        np.negative(M, out=M)
    return M


def factored(tps_phi, x, sim_phi, sign_tps: float) -> tuple[Saddle, Saddle] | None:
    """(the TPS's system, the fallback's) as :class:`Saddle` factors, or None.

    ``tps_phi`` (K, K) the TPS's kernel matrix on the normalised template points ``x`` (K, D)
    (polynomial part [1, x], conditionally definite with ``sign_tps``); ``sim_phi`` the
    fallback's (φ(r) = r, polynomial part 1, sign -1), or None when it is ``tps_phi`` (3-D: one
    factor for both, module docstring).
    """
    K, D = x.shape
    q = D + 1
    house = Householder(np.hstack([np.ones((K, 1)), x]))
    X = house.two_sided(tps_phi)
    if sim_phi is None:
        blocks = [(q, K), (1, q)]
        Linv = _factor(_projected(X, blocks, sign_tps))
        if Linv is None:
            return None
        n = K - q
        tps = Saddle(tps_phi, house, q, blocks[:1], Linv[:n, :n], sign_tps)
        return tps, Saddle(tps_phi, house, 1, blocks, Linv, sign_tps)
    Linv = _factor(_projected(X, [(q, K)], sign_tps))
    if Linv is None:
        return None
    tps = Saddle(tps_phi, house, q, [(q, K)], Linv, sign_tps)
    house1 = Householder(np.ones((K, 1)))
    Linv1 = _factor(_projected(house1.two_sided(sim_phi), [(1, K)], -1.0))
    if Linv1 is None:
        return None
    return tps, Saddle(sim_phi, house1, 1, [(1, K)], Linv1, -1.0)


class Dense:
    """:class:`Saddle`'s interface over the inverse's first K columns ``cols`` (K + q, K), given."""

    def __init__(self, cols: np.ndarray):
        self.cols = cols

    def gram(self, f: np.ndarray) -> np.ndarray:
        return self.cols[:len(f)] @ f

    def solve(self, f: np.ndarray) -> np.ndarray:
        return self.cols @ f

    def diagonal(self) -> np.ndarray:
        return np.diagonal(self.cols[:self.cols.shape[1]])

    def full(self) -> np.ndarray:
        return self.cols


# The general inverses (one Householder reflector at a time): what a factor is checked against,
# and what the warp takes where a factorisation fails.


def _saddle_inverse(phi: np.ndarray, P: np.ndarray, sign: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Blocks of the inverse of the interpolation system [[phi, P], [Pᵀ, 0]], or None.

    ``phi`` (K, K) is a conditionally definite kernel matrix (``sign`` = +1: positive, -1:
    negative definite on the vectors c with Pᵀ c = 0), ``P`` (K, Q) its polynomial part.  With
    P = Q R (Householder) and the last K - Q columns Z of Q spanning {c : Pᵀ c = 0}, the inverse's
    top-left block is G = Z (Zᵀ phi Z)⁻¹ Zᵀ and its bottom-left block Eᵀ = R⁻¹ Q₁ᵀ (I - phi G);
    Zᵀ phi Z is ``sign`` × positive definite, so a Cholesky factorisation inverts it: about K³
    flops for the whole inverse, against 2.7 K³ for a general LU inverse.  None when the
    factorisation fails (a kernel matrix that is not definite: a ridge in 3-D, or rounding),
    and the caller inverts the whole system instead.

    Returns
    -------
    G : ndarray, shape (K, K)
    Et : ndarray, shape (Q, K)
    """
    # lazy: loads scipy, which importing this module does not
    from scipy.linalg import lapack

    K, Q = P.shape
    h, tau = np.linalg.qr(P, mode="raw")
    h = h.T  # (K, Q): R on and above the diagonal, the reflectors below (unit diagonal implied)
    vs = []
    for j in range(Q):
        v = np.zeros(K)
        v[j] = 1.0
        v[j + 1:] = h[j + 1:, j]
        vs.append(v)

    def both_sides(X: np.ndarray, order) -> np.ndarray:  # X <- H_j X H_j for j in order
        for j in order:
            v, t = vs[j], tau[j]
            X -= np.outer(t * v, v @ X)
            X -= np.outer(X @ v, t * v)
        return X

    X = both_sides(phi.copy(), range(Q))  # Qᵀ phi Q
    M = sign * X[Q:, Q:]
    c, info = lapack.dpotrf(M, lower=0, clean=0, overwrite_a=1)
    if info != 0:
        return None
    Minv, info = lapack.dpotri(c, lower=0, overwrite_c=1)
    if info != 0:
        return None
    Minv = np.triu(Minv)
    Minv += np.triu(Minv, 1).T
    Y = np.zeros((K, K))
    Y[Q:, Q:] = sign * Minv
    G = both_sides(Y, range(Q - 1, -1, -1))  # Q Y Qᵀ
    G = 0.5 * (G + G.T)
    Q1 = _apply_q(vs, tau, np.eye(K, Q))  # the first Q columns of Q
    W = Q1.T - (Q1.T @ phi) @ G  # Q₁ᵀ (I - phi G)
    Et = np.linalg.solve(np.triu(h[:Q, :Q]), W)
    return G, Et


def _apply_q(vs, tau, X: np.ndarray) -> np.ndarray:
    """Q X for Q = H_1 ... H_q (Householder reflectors ``vs``, ``tau``)."""
    for j in range(len(vs) - 1, -1, -1):
        X = X - np.outer(tau[j] * vs[j], vs[j] @ X)
    return X


def _inverse(phi: np.ndarray, P: np.ndarray, sign: float) -> np.ndarray:
    """A⁻¹[:, :K] of A = [[phi, P], [Pᵀ, 0]], shape (K + Q, K): by :func:`_saddle_inverse`, or by
    a general inverse of A when that fails."""
    K, Q = P.shape
    got = _saddle_inverse(phi, P, sign)
    if got is not None:
        return np.vstack(got)
    A = np.zeros((K + Q, K + Q))
    A[:K, :K] = phi
    A[:K, K:] = P
    A[K:, :K] = P.T
    return np.linalg.inv(A)[:, :K]


def _complete(cols: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """The whole inverse (K + Q, K + Q) of A = [[phi, P], [Pᵀ, 0]] from its first K columns
    ``cols`` = [G; Eᵀ] (what :func:`_inverse` gives): the last block is J = -Eᵀ phi E (from
    phi E + P J = 0 and Pᵀ E = I), O(K² Q)."""
    K = phi.shape[0]
    n = len(cols)
    out = np.empty((n, n))
    out[:, :K] = cols
    out[:K, K:] = cols[K:].T
    J = -(cols[K:] @ phi) @ cols[K:].T
    out[K:, K:] = 0.5 * (J + J.T)
    return out
