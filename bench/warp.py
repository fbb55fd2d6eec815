"""When does the TPS stop paying?  The amplification limit of ``hila_lang.osila.tps.fit_warp``.

Synthetic pairs with a KNOWN answer (no evaluation data set is used):

- a template path: a random smooth curve (three harmonics and a drift per axis), scaled to unit
  extent, 100 points;
- a true map g from template to task: a random linear part I + E (entries of E ~ N(0, alpha):
  anisotropic stretch and shear, as between two people's versions of a movement) plus three
  Gaussian bumps (amplitude ~ N(0, beta), width 0.3: local bends); the task path is g(template);
- K = D+1..8 ICPs: points of the template path (as boundary constraints) or points around it (as
  scene features), half and half; their task positions are g(ICP) plus noise N(0, sigma) — how
  well an ICP is located (sigma = 0.01, i.e. 1 % of the extent, is OSILA's default distortion
  threshold: "the same place" at the method's own tolerance);
- the template as a sensor measures it: the path plus the same noise N(0, sigma), from which
  OSILA's default precision of the pairs is measured (``hila_lang.osila.noise.amplification_limit``:
  the template's position noise, the sensor's, carried by the similarity's scale).

For each pair the exact TPS and the similarity fallback (least-squares similarity plus exact
interpolation of its residuals) map the template; the RMS error against g(template) is binned
by the TPS's amplification Λ on the path (the Lebesgue constant, see ``hila_lang.osila.tps``).
The threshold is where the TPS stops beating the fallback.  Several (sigma, alpha, beta) rows are
printed to show how the crossover moves: more ICP noise or less true deformation favours the
fallback earlier.  Last, per scenario, the error of always using the TPS, always the fallback,
and ``fit_warp``'s own choice (the fallback for K = D + 1 pairs; otherwise the map with the
smaller leave-one-out error at the ICPs, the TPS only while Λ is within the data's limit: Λ·σ <=
the similarity's RMS residual at the pairs), beside the same choice with the former fixed limit
(:data:`FORMER_LIMIT`, Λ <= 6 in 2-D and 8 in 3-D, which these bins once measured).  Not a test.
Seeded; about a minute.

    python bench/warp.py [--pairs 4000]
"""

from __future__ import annotations

import argparse

import numpy as np

from hila_lang.evaluation.ablation import FORMER_LIMIT  # the limit these bins once measured
from hila_lang.osila.fallback import fit_similarity
from hila_lang.osila.noise import position_noise
from hila_lang.osila.tps import _similarity, _similarity_parts, _tps, affine_rank, amplification, fit_warp

EDGES = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 64, np.inf)
SCENARIOS = ((0.01, 0.1, 0.05), (0.005, 0.1, 0.05), (0.02, 0.1, 0.05), (0.01, 0.05, 0.02), (0.01, 0.2, 0.1))


def curve(rng, dim: int, T: int = 100) -> np.ndarray:
    t = np.linspace(0, 1, T)[:, None]
    p = rng.normal(0, 1, (1, dim)) * t
    for m in (1, 2, 3):
        p = p + rng.normal(0, 1 / m, (1, dim)) * np.sin(m * np.pi * t + rng.uniform(0, 2 * np.pi, (1, dim)))
    p -= p.mean(0)
    return p / np.ptp(p, axis=0).max()


def true_map(rng, dim: int, alpha: float, beta: float):
    lin = np.eye(dim) + rng.normal(0, alpha, (dim, dim))
    centres, amps = rng.uniform(-0.5, 0.5, (3, dim)), rng.normal(0, beta, (3, dim))

    def g(x):
        y = x @ lin.T
        for c, a in zip(centres, amps):
            y = y + a * np.exp(-((x - c) ** 2).sum(1) / (2 * 0.3**2))[:, None]
        return y

    return g


def run(dim: int, sigma: float, alpha: float, beta: float, pairs: int, seed: int) -> np.ndarray:
    """Rows (Λ, TPS error, fallback error, error of fit_warp's choice, K, error of the choice with
    the former fixed limit) for ``pairs`` synthetic pairs."""
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(pairs):
        path, g = curve(rng, dim), true_map(rng, dim, alpha, beta)
        K = int(rng.integers(dim + 1, 9))
        if rng.random() < 0.5:
            src = path[np.sort(rng.choice(len(path), K, replace=False))]
        else:
            src = rng.uniform(path.min(0) - 0.2, path.max(0) + 0.2, (K, dim))
        dst = g(src) + rng.normal(0, sigma, src.shape)
        if affine_rank(src) < dim:
            continue
        # the two maps themselves, without fit_warp's choice between them
        tps = _tps(src, dst, np.zeros(K))
        fallback = _similarity(src, dst, *_similarity_parts(src, dst, np.zeros(K), dim), None)
        # what OSILA uses: its own choice between the two; the pairs' precision as OSILA measures it
        # by default, on the template as the sensor saw it
        measured = path + rng.normal(0, sigma, path.shape)
        scale = fit_similarity(src, dst, dim)[0]
        chosen = fit_warp(src, dst, on=path, precision=position_noise(measured) * scale)
        former = fit_warp(src, dst, on=path, max_amplification=FORMER_LIMIT[dim])
        truth = g(path)
        err = [float(np.sqrt(((m - truth) ** 2).sum(1).mean()))
               for m in (tps(path), fallback(path), chosen.mapped, former.mapped)]
        rows.append((amplification(src, path), *err[:3], K, err[3]))
    return np.array(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=4000, help="synthetic pairs per scenario (default 4000)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(f"the amplification limit: the data's (Λ·σ <= the similarity's residual); the former fixed one: {FORMER_LIMIT}")
    print("median RMS error (unit extent) of the exact TPS / the similarity fallback, and the share of pairs")
    print("where the TPS is better, per amplification bin")
    for dim in (2, 3):
        for sigma, alpha, beta in SCENARIOS:
            a = run(dim, sigma, alpha, beta, args.pairs, args.seed)
            print(f"\n{dim}-D, ICP noise sigma = {sigma}, stretch alpha = {alpha}, bends beta = {beta} ({len(a)} pairs)")
            cross = None
            for lo, hi in zip(EDGES[:-1], EDGES[1:]):
                m = (a[:, 0] >= lo) & (a[:, 0] < hi)
                if m.sum() < 10:
                    continue
                tps, fb = np.median(a[m, 1]), np.median(a[m, 2])
                if cross is None and tps > fb:
                    cross = lo
                print(f"  Λ {lo:>4g}-{hi:<4g} n = {int(m.sum()):4d}   TPS {tps:.4f}   fallback {fb:.4f}   "
                      f"TPS better in {100 * np.mean(a[m, 1] < a[m, 2]):3.0f}%")
            print(f"  -> the TPS's median error exceeds the fallback's from Λ = {cross}")
            med, mean = np.median(a[:, [1, 2, 3, 5]], axis=0), a[:, [1, 2, 3, 5]].mean(0)
            print(f"  all pairs, median / mean error: always TPS {med[0]:.4f} / {mean[0]:.4f}, always fallback "
                  f"{med[1]:.4f} / {mean[1]:.4f}, fit_warp's choice {med[2]:.4f} / {mean[2]:.4f} "
                  f"(with the former limit {med[3]:.4f} / {mean[3]:.4f})")


if __name__ == "__main__":
    main()
