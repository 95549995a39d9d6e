"""Evidence for the loss functions of ``pcgeom.losses``.

Each test checks a loss against something independent of its implementation:
a naive loop of the paper's formula, an analytic ground truth (HAND(X, X) -> 0,
LEG = 0 for a similarity with the matching conformal factor), the paper's
Theorem 1 (Boltzmann error bound) and Theorem 2 (LEG bounds angle distortion),
SciPy's Hausdorff distance, or ``torch.autograd.gradcheck`` in float64. Every entry of the
backend tables (``LEG_BACKENDS``, ``HAND_BACKENDS``) is checked against the dense reference.
"""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest
import torch
from scipy.spatial.distance import directed_hausdorff, euclidean

from pcgeom.losses import (
    HAND_BACKENDS,
    LEG_BACKENDS,
    boltzmann,
    hand,
    hand_chunked,
    hand_dense,
    hand_knn,
    landmark_hand,
    leg,
    leg_chunked,
    leg_dense,
    leg_pairs,
    modified_hausdorff,
    pairwise_distances,
)
from pcgeom.metrics import hausdorff

DTYPE = torch.float64


def _rng(seed: int) -> np.random.Generator:
    return np.random.default_rng(seed)


def _t(a) -> torch.Tensor:
    return torch.as_tensor(np.asarray(a, dtype=np.float64), dtype=DTYPE)


# --------------------------------------------------------------------------- #
# Theorem 1 (paper, "boltzmann operator error bound"), written independently
# of the library, in NumPy.
# --------------------------------------------------------------------------- #
def _theorem1_max_bound(x: np.ndarray, alpha: float) -> float:
    r"""Right side of Theorem 1 for the max: (n/m) e^{-alpha (x_max - x_{m+1})} ||x||.

    ``m`` is the multiplicity of the max and ``x_{m+1}`` the largest value below
    it; when all values are equal the operator is exact and the bound is 0.
    """
    x = np.asarray(x, dtype=np.float64)
    xmax = x.max()
    m = int(np.count_nonzero(x == xmax))
    below = x[x < xmax]
    if below.size == 0:
        return 0.0
    gap = xmax - below.max()
    return x.size / m * math.exp(-alpha * gap) * float(np.linalg.norm(x))


def _theorem1_min_bound(x: np.ndarray, alpha: float) -> float:
    """Theorem 1 for ``B_{-alpha}`` and the min: the max bound of ``-x`` (same norm)."""
    return _theorem1_max_bound(-np.asarray(x, dtype=np.float64), alpha)


def _naive_boltzmann(x: np.ndarray, alpha: float) -> float:
    """The defining quotient sum(x e^{a x}) / sum(e^{a x}), without any shift."""
    with np.errstate(over="ignore", invalid="ignore"):
        w = np.exp(alpha * x)
        return float((x * w).sum() / w.sum())


# =========================================================================== #
# 1. Boltzmann operator
# =========================================================================== #
ALPHAS = [-1e3, -50.0, -5.0, -0.3, 0.0, 0.3, 5.0, 50.0, 1e3]


@pytest.mark.parametrize("alpha", ALPHAS)
def test_boltzmann_between_min_and_max(alpha):
    x = _t(_rng(0).normal(size=(64, 9)) * 3.0)  # 64 random vectors of length 9
    b = boltzmann(x, alpha, dim=1)  # (64,)
    assert b.shape == (64,)
    lo, hi = x.min(dim=1).values, x.max(dim=1).values
    tol = 1e-12
    assert torch.all(b >= lo - tol) and torch.all(b <= hi + tol)
    if alpha == 0.0:  # zero sharpness is the plain mean
        torch.testing.assert_close(b, x.mean(dim=1), rtol=0, atol=1e-13)


@pytest.mark.parametrize("alpha", [0.1, 2.0, 40.0, 700.0])
def test_boltzmann_negative_alpha_is_reflected_positive(alpha):
    x = _t(_rng(1).uniform(-2, 2, size=(20, 13)))
    torch.testing.assert_close(
        boltzmann(x, -alpha, dim=1), -boltzmann(-x, alpha, dim=1), rtol=0, atol=1e-13
    )


@pytest.mark.parametrize("alpha", [-20.0, -3.0, -0.5, 0.5, 3.0, 20.0])
def test_boltzmann_matches_naive_formula(alpha):
    x = _rng(2).uniform(-3, 3, size=(10, 17))
    got = boltzmann(_t(x), alpha, dim=1).numpy()
    want = np.array([_naive_boltzmann(row, alpha) for row in x])
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-13)
    # reducing along another dim is the same operator on the transposed data
    got_t = boltzmann(_t(x.T), alpha, dim=0).numpy()
    np.testing.assert_allclose(got_t, want, rtol=1e-12, atol=1e-13)


def test_boltzmann_finite_where_naive_overflows():
    x = np.array([10.0, 9.0, 3.0, -4.0, 10.0 - 1e-3])
    alpha = 1e4
    assert not np.isfinite(_naive_boltzmann(x, alpha))  # the test is meaningful
    assert not np.isfinite(_naive_boltzmann(x, -alpha * 1e3 / 4))
    b_max = boltzmann(_t(x), alpha)
    b_min = boltzmann(_t(x), -alpha * 1e3 / 4)
    assert torch.isfinite(b_max) and torch.isfinite(b_min)
    # with gaps of 1e-3 and alpha = 1e4, Theorem 1 puts both within ~1e-3 of the extremes
    assert abs(b_max.item() - 10.0) <= _theorem1_max_bound(x, alpha) + 1e-12
    assert abs(b_max.item() - 10.0) < 1e-3
    assert abs(b_min.item() - (-4.0)) < 1e-12


@pytest.mark.parametrize("alpha", [0.5, 2.0, 10.0, 50.0, 200.0, 1e3, 1e4])
def test_boltzmann_theorem1_error_bound(alpha):
    rng = _rng(3)
    # integer-valued entries so the max (and min) are repeated: multiplicity m > 1 occurs
    x = rng.integers(-5, 6, size=(40, 12)).astype(np.float64) * 0.1
    x[::5] = rng.normal(size=(8, 12))  # and some rows with distinct values, m = 1
    x[7] = 0.3  # a constant row: exact, zero bound
    b_max = boltzmann(_t(x), alpha, dim=1).numpy()
    b_min = boltzmann(_t(x), -alpha, dim=1).numpy()
    multiplicities = set()
    for row, bmax, bmin in zip(x, b_max, b_min):
        multiplicities.add(int(np.count_nonzero(row == row.max())))
        assert abs(bmax - row.max()) <= _theorem1_max_bound(row, alpha) + 1e-13
        assert abs(bmin - row.min()) <= _theorem1_min_bound(row, alpha) + 1e-13
    assert 1 in multiplicities and max(multiplicities) > 1
    assert _theorem1_max_bound(x[7], alpha) == 0.0 and abs(b_max[7] - 0.3) < 1e-15


def test_boltzmann_theorem1_rate_is_sharp():
    """The exponent of Theorem 1 is the true rate: B_a(x) - max ~ -(k/m) gap e^{-a gap}.

    ``m`` copies of the max and ``k`` copies of the runner-up, ``gap`` apart; the
    other values contribute at a faster rate.
    """
    x = np.array([1.0, 1.0, 0.8, 0.8, 0.8, 0.2, -0.5])  # m = 2, k = 3, gap = 0.2
    for alpha in (50.0, 80.0, 110.0):
        err = boltzmann(_t(x), alpha).item() - 1.0
        assert err < 0.0
        assert -err <= _theorem1_max_bound(x, alpha)
        # next-order terms are O(e^{-alpha gap}) relative: 7e-5 at alpha = 50
        assert err * math.exp(alpha * 0.2) == pytest.approx(-1.5 * 0.2, rel=1e-3)


# =========================================================================== #
# 2. HAND and exact Hausdorff distances
# =========================================================================== #
def _naive_directed(A: np.ndarray, B: np.ndarray) -> float:
    """max_a min_b |a - b| as a plain double loop."""
    return max(min(euclidean(a, b) for b in B) for a in A)


@pytest.mark.parametrize("n, m, dim", [(9, 9, 2), (13, 7, 2), (5, 21, 3)])
def test_hausdorff_and_modified_hausdorff_match_naive(n, m, dim):
    rng = _rng(10 + n)
    Y, W = rng.uniform(size=(n, dim)), rng.normal(size=(m, dim))
    yw, wy = _naive_directed(Y, W), _naive_directed(W, Y)
    assert math.isclose(yw, directed_hausdorff(Y, W)[0], rel_tol=1e-12)
    assert math.isclose(wy, directed_hausdorff(W, Y)[0], rel_tol=1e-12)
    assert abs(hausdorff(Y, W) - max(yw, wy)) < 1e-12  # the exact NumPy measure
    assert abs(modified_hausdorff(_t(Y), _t(W)).item() - (yw + wy)) < 1e-12
    # the pairwise distances themselves
    d = pairwise_distances(_t(Y), _t(W)).numpy()
    want = np.array([[euclidean(a, b) for b in W] for a in Y])
    np.testing.assert_allclose(d, want, rtol=1e-13, atol=1e-15)


def test_hand_of_a_set_with_itself_tends_to_zero():
    X = _t(_rng(20).uniform(size=(60, 2)))  # unit square
    values = [hand(X, X, a).item() for a in (10.0, 100.0, 1000.0, 10000.0)]
    assert all(v > 0 for v in values[:2])  # finite alpha: a soft min above 0
    assert values[0] > values[1] > values[2] >= values[3] >= 0.0
    assert values[0] > 1e-3  # alpha = 10 is far from the limit ...
    assert values[1] < 1e-2 and values[2] < 1e-4  # ... larger alpha approach it
    assert values[3] < 1e-12  # at alpha = 1e4 only the 1e-15 distance clamp is left
    assert modified_hausdorff(X, X).item() < 1e-14


def _directed_hand_bound(d: np.ndarray, alpha: float) -> float:
    r"""Bound on |B_a({B_-a(d_i.)}_i) - max_i min_k d_ik| from Theorem 1 applied twice.

    Let t_i = min_k d_ik, b_i = B_{-alpha}(d_i.) and z between t and b.
    * inner: |b_i - t_i| <= eps_in = max_i (M/l_i) e^{-alpha s_min(d_i.)} ||d_i.||;
    * outer: |B_alpha(t) - max t| <= eps_out = (N/m) e^{-alpha s_max(t)} ||t||;
    * Lipschitz: dB_alpha/dz_i = p_i (1 + alpha (z_i - B_alpha(z))), p = softmax(alpha z),
      so ||grad||_1 <= 1 + alpha sum_i p_i |z_i - B| <= 1 + alpha range(z), and
      range(z) <= max(range(t), range(b)) on the segment [t, b]; hence
      |B_alpha(b) - B_alpha(t)| <= (1 + alpha rho) eps_in (Hoelder, l1 x l_inf).
    Total: eps_out + (1 + alpha rho) eps_in.
    """
    t = d.min(axis=1)
    b = np.array([_naive_row_softmin(row, alpha) for row in d])
    eps_in = max(_theorem1_min_bound(row, alpha) for row in d)
    eps_out = _theorem1_max_bound(t, alpha)
    rho = max(np.ptp(t), np.ptp(b))
    return eps_out + (1.0 + alpha * rho) * eps_in


def _naive_row_softmin(row: np.ndarray, alpha: float) -> float:
    """B_{-alpha}(row) with an explicit min shift (an independent stable evaluation)."""
    w = np.exp(-alpha * (row - row.min()))
    return float((row * w).sum() / w.sum())


def test_hand_tends_to_modified_hausdorff_within_theorem1_bound():
    rng = _rng(21)
    Y = rng.uniform(size=(17, 2))
    W = rng.uniform(size=(29, 2)) * 1.3 - 0.1  # unequal sizes and supports
    Yt, Wt = _t(Y), _t(W)
    d = np.array([[euclidean(a, b) for b in W] for a in Y])  # (N, M)
    target = _naive_directed(Y, W) + _naive_directed(W, Y)
    assert abs(modified_hausdorff(Yt, Wt).item() - target) < 1e-12

    alphas = [3.0, 10.0, 30.0, 100.0, 300.0, 1e3, 3e3, 1e4, 3e4]
    errors, bounds = [], []
    for a in alphas:
        # inner operator rows: Theorem 1 directly, both directions
        for rows in (d, d.T):
            soft = boltzmann(_t(rows), -a, dim=1).numpy()
            for row, s in zip(rows, soft):
                assert abs(s - row.min()) <= _theorem1_min_bound(row, a) + 1e-13
        err = abs(hand(Yt, Wt, a).item() - target)
        bound = _directed_hand_bound(d, a) + _directed_hand_bound(d.T, a)
        assert err <= bound + 1e-12, (a, err, bound)
        errors.append(err)
        bounds.append(bound)
    assert all(e1 > e2 for e1, e2 in zip(errors, errors[1:]) if e1 > 1e-13)
    assert errors[0] > 1e-2  # small alpha is a visibly smooth approximation
    assert errors[alphas.index(1e3)] < 1e-3
    assert bounds[-1] < 1e-6  # the bound has bitten: the check above is not vacuous


def test_hand_accepts_sets_of_unequal_size_and_is_symmetric():
    rng = _rng(22)
    Y, W = _t(rng.uniform(size=(5, 2))), _t(rng.uniform(size=(23, 2)))
    h = hand(Y, W, 20.0)
    assert h.shape == () and torch.isfinite(h) and h.item() > 0
    # the two directed terms swap: H(Y, W) = H(W, Y)
    torch.testing.assert_close(h, hand(W, Y, 20.0), rtol=1e-13, atol=0)
    # HAND uses the Boltzmann operator exactly as the equation DDHD writes it
    d = pairwise_distances(Y, W)
    manual = boltzmann(boltzmann(d, -20.0, dim=1), 20.0, dim=0) + boltzmann(
        boltzmann(d.T, -20.0, dim=1), 20.0, dim=0
    )
    torch.testing.assert_close(h, manual, rtol=1e-14, atol=0)


# =========================================================================== #
# 3. LEG
# =========================================================================== #
def _naive_D(xi, xj, yi, yj, li, lj, sigma) -> float:
    """D_ij of the paper with 1 / lambda_ij = l_i + l_j, scalar Python arithmetic."""
    dx2 = sum((a - b) ** 2 for a, b in zip(xi, xj))
    dy2 = sum((a - b) ** 2 for a, b in zip(yi, yj))
    lam = 1.0 / (li + lj)
    return (math.exp(-dx2 / sigma**2) - math.exp(-dy2 / (sigma**2 * lam**2))) ** 2


def _leg_problem(seed: int, n: int = 7):
    rng = _rng(seed)
    X = rng.normal(size=(n, 3))
    Y = rng.normal(size=(n, 2))
    lam_inv = rng.uniform(0.2, 0.9, size=n)
    return X, Y, lam_inv


@pytest.mark.parametrize("sigma", [0.4, 1.0, 3.0])
def test_leg_matches_naive_double_loop(sigma):
    X, Y, l = _leg_problem(30)
    N = len(X)
    want = sum(
        _naive_D(X[i], X[j], Y[i], Y[j], l[i], l[j], sigma) for i in range(N) for j in range(N)
    ) / N**2
    got = leg(_t(X), _t(Y), _t(l), sigma).item()
    assert want > 1e-4  # non-trivial value
    assert math.isclose(got, want, rel_tol=1e-12, abs_tol=1e-15)


def test_leg_pairs_with_all_pairs_equals_leg():
    X, Y, l = (_t(a) for a in _leg_problem(31))
    N = X.shape[0]
    i, j = torch.meshgrid(torch.arange(N), torch.arange(N), indexing="ij")
    full = leg(X, Y, l, 0.8)
    torch.testing.assert_close(leg_pairs(X, Y, l, 0.8, i.reshape(-1), j.reshape(-1)), full,
                               rtol=1e-13, atol=0)
    # order of pairs does not matter; unit weights are the unweighted mean
    perm = torch.from_numpy(_rng(0).permutation(N * N))
    ones = torch.ones(N * N, dtype=DTYPE)
    torch.testing.assert_close(
        leg_pairs(X, Y, l, 0.8, i.reshape(-1)[perm], j.reshape(-1)[perm], weight=ones), full,
        rtol=1e-13, atol=0,
    )


def test_leg_pairs_weighted_matches_naive_weighted_mean():
    X, Y, l = _leg_problem(32)
    rng = _rng(33)
    i = rng.integers(0, 7, size=25)
    j = rng.integers(0, 7, size=25)
    w = rng.uniform(0.0, 3.0, size=25)
    sigma = 0.9
    Ds = [_naive_D(X[a], X[b], Y[a], Y[b], l[a], l[b], sigma) for a, b in zip(i, j)]
    want = sum(wp * D for wp, D in zip(w, Ds)) / w.sum()
    got = leg_pairs(_t(X), _t(Y), _t(l), sigma, torch.from_numpy(i), torch.from_numpy(j),
                    weight=_t(w)).item()
    assert math.isclose(got, want, rel_tol=1e-12)
    unweighted = sum(Ds) / len(Ds)
    assert abs(want - unweighted) > 1e-4  # the weights matter here
    got_u = leg_pairs(_t(X), _t(Y), _t(l), sigma, torch.from_numpy(i), torch.from_numpy(j))
    assert math.isclose(got_u.item(), unweighted, rel_tol=1e-12)


def _rotation3(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _similarity_problem(seed: int = 40, n: int = 40):
    """Planar points embedded in 3D by a rotation, and a 2D similarity of them."""
    rng = _rng(seed)
    P = rng.uniform(size=(n, 2))
    X = np.c_[P, np.zeros(n)] @ _rotation3(rng).T + rng.normal(size=3)
    s, theta = 1.7, 0.6
    R2 = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    Y = s * P @ R2.T + np.array([0.3, -2.0])
    return X, Y, P, s


@pytest.mark.parametrize("sigma", [0.1, 0.5, 2.0])
def test_leg_vanishes_for_a_similarity_with_its_conformal_factor(sigma):
    X, Y, P, s = _similarity_problem()
    n = len(X)
    # 1 / lambda_ij = l_i + l_j and lambda_ij = s for a similarity: l = 1 / (2 s)
    lam_inv = torch.full((n,), 1.0 / (2.0 * s), dtype=DTYPE)
    assert leg(_t(X), _t(Y), lam_inv, sigma).item() < 1e-12
    # wrong conformal factor: clearly positive
    assert leg(_t(X), _t(Y), lam_inv * 1.3, sigma).item() > 1e-4
    assert leg(_t(X), _t(Y), lam_inv / 1.3, sigma).item() > 1e-4
    # a non-similar (sheared) map is not a zero whatever constant l is used
    shear = np.array([[1.0, 0.6], [0.0, 1.0]])
    Y_shear = s * P @ shear.T
    best = min(
        leg(_t(X), _t(Y_shear), torch.full((n,), c / (2.0 * s), dtype=DTYPE), sigma).item()
        for c in np.linspace(0.5, 1.5, 41)
    )
    assert best > 1e-4


# --------------------------------------------------------------------------- #
# LEG backend table: every entry against the dense reference
# --------------------------------------------------------------------------- #
def _all_ordered_pairs(n: int) -> tuple[torch.Tensor, torch.Tensor]:
    i, j = torch.meshgrid(torch.arange(n), torch.arange(n), indexing="ij")
    return i.reshape(-1), j.reshape(-1)


def test_leg_backend_table():
    assert LEG_BACKENDS == {"dense": leg_dense, "chunked": leg_chunked, "pairs": leg_pairs}
    assert HAND_BACKENDS == {"dense": hand_dense, "chunked": hand_chunked, "knn": hand_knn}


def test_leg_auto_picks_pairs_when_given_and_dense_otherwise():
    X, Y, l = (_t(a) for a in _leg_problem(34))
    rng = _rng(35)
    i, j = torch.from_numpy(rng.integers(0, 7, 12)), torch.from_numpy(rng.integers(0, 7, 12))
    w = _t(rng.uniform(0.1, 2.0, 12))
    dense = leg_dense(X, Y, l, 0.8)
    assert leg(X, Y, l, 0.8).item() == dense.item()
    assert leg(X, Y, l, 0.8, backend="auto").item() == dense.item()
    assert leg(X, Y, l, 0.8, backend="dense").item() == dense.item()
    sparse = leg_pairs(X, Y, l, 0.8, i, j)
    assert abs(sparse.item() - dense.item()) > 1e-3  # 12 random pairs are not all N^2 pairs
    assert leg(X, Y, l, 0.8, pairs=(i, j)).item() == sparse.item()
    assert leg(X, Y, l, 0.8, pairs=(i, j), backend="pairs").item() == sparse.item()
    weighted = leg_pairs(X, Y, l, 0.8, i, j, weight=w)
    assert abs(weighted.item() - sparse.item()) > 1e-4  # the weights matter here
    assert leg(X, Y, l, 0.8, pairs=(i, j), weight=w).item() == weighted.item()


def test_leg_pairs_backend_with_all_pairs_equals_dense_value_and_gradient():
    X, Y0, l0 = (_t(a) for a in _leg_problem(36))
    pairs = _all_ordered_pairs(len(X))
    grads = {}
    for backend, kwargs in (("dense", {}), ("pairs", {"pairs": pairs})):
        Y = Y0.clone().requires_grad_(True)
        l = l0.clone().requires_grad_(True)
        value = leg(X, Y, l, 0.8, backend=backend, **kwargs)
        value.backward()
        grads[backend] = (value.detach(), Y.grad, l.grad)
    assert grads["dense"][0].item() > 1e-4  # non-trivial value
    assert grads["dense"][1].abs().max() > 1e-4 and grads["dense"][2].abs().max() > 1e-4
    for got, want in zip(grads["pairs"], grads["dense"]):
        torch.testing.assert_close(got, want, rtol=1e-12, atol=1e-15)


_DENSE_TAKES_NO_PAIRS = r"^leg: the 'dense' backend uses all pairs; do not pass pairs$"


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (lambda n: {"backend": "keops"},
         r"^leg: unknown backend 'keops'; choose one of: auto, dense, chunked, pairs$"),
        (lambda n: {"backend": "pairs"}, r"^leg: the 'pairs' backend needs pairs=\(i, j\)$"),
        (lambda n: {"backend": "dense", "pairs": _all_ordered_pairs(n)}, _DENSE_TAKES_NO_PAIRS),
        (lambda n: {"weight": torch.ones(n * n, dtype=DTYPE)},
         r"^leg: the 'dense' backend takes a weight of shape \(N, N\) = \(7, 7\), got \(49,\)$"),
        (lambda n: {"backend": "chunked", "pairs": _all_ordered_pairs(n)},
         r"^leg: the 'chunked' backend uses all pairs; do not pass pairs$"),
        (lambda n: {"backend": "chunked", "weight": torch.ones(n, n + 1, dtype=DTYPE)},
         r"^leg: the 'chunked' backend takes a weight of shape \(N, N\) = \(7, 7\), "
         r"got \(7, 8\)$"),
        (lambda n: {"pairs": _all_ordered_pairs(n), "weight": torch.ones(n, n, dtype=DTYPE)},
         r"^leg: the 'pairs' backend takes a weight of shape \(P,\) = \(49,\), got \(7, 7\)$"),
    ],
    ids=["unknown", "pairs-without-pairs", "dense-with-pairs", "auto-with-a-flat-weight",
         "chunked-with-pairs", "chunked-weight-shape", "pairs-weight-shape"],
)
def test_leg_backend_errors(kwargs, match):
    X, Y, l = (_t(a) for a in _leg_problem(37))
    with pytest.raises(ValueError, match=match):
        leg(X, Y, l, 0.8, **kwargs(len(X)))


def test_hand_dispatch():
    rng = _rng(38)
    Y, W = _t(rng.uniform(size=(6, 2))), _t(rng.uniform(size=(9, 2)))
    dense = hand_dense(Y, W, 5.0)
    assert hand(Y, W, 5.0).item() == dense.item()
    assert hand(Y, W, 5.0, backend="auto").item() == dense.item()
    assert hand(Y, W, 5.0, backend="dense").item() == dense.item()
    match = r"^hand: unknown backend 'pairs'; choose one of: auto, dense, chunked, knn$"
    with pytest.raises(ValueError, match=match):
        hand(Y, W, 5.0, backend="pairs")


def _value_and_grads(fn, *inputs):
    """``fn(*inputs)`` and its gradient with respect to each input (float64 copies)."""
    leaves = [x.detach().clone().requires_grad_(True) for x in inputs]
    value = fn(*leaves)
    return (value.detach(), *torch.autograd.grad(value, leaves))


def _assert_same_value_and_grads(got, want, *, rtol=1e-12, atol=1e-14):
    assert want[0].abs().item() > 1e-4  # a non-trivial value
    assert all(g.abs().max().item() > 1e-6 for g in want[1:])  # and non-trivial gradients
    for a, b in zip(got, want):
        torch.testing.assert_close(a, b, rtol=rtol, atol=atol)


@pytest.mark.parametrize("block", [1, 3, 7, 40])  # one row per block, uneven, exact, all rows
@pytest.mark.parametrize("weighted", [False, True])
def test_leg_chunked_equals_dense_value_and_gradients(block, weighted):
    X, Y, l = (_t(a) for a in _leg_problem(39, n=20))
    w = _t(_rng(40).uniform(size=(20, 20)) > 0.3) if weighted else None
    want = _value_and_grads(lambda y, li: leg_dense(X, y, li, 0.8, weight=w), Y, l)
    got = _value_and_grads(lambda y, li: leg_chunked(X, y, li, 0.8, weight=w, block=block), Y, l)
    _assert_same_value_and_grads(got, want)


def test_leg_weight_is_a_weighted_mean_and_a_zero_weight_drops_the_pair():
    X, Y, l = (_t(a) for a in _leg_problem(41, n=9))
    w = _t(_rng(42).uniform(0.0, 2.0, size=(9, 9)))
    w[2, :] = 0.0  # row 2 is dropped: moving y_2 alone must not change the energy
    i, j = _all_ordered_pairs(9)
    want = leg_pairs(X, Y, l, 0.8, i, j, weight=w.reshape(-1))
    for backend in ("dense", "chunked"):
        got = leg(X, Y, l, 0.8, weight=w, backend=backend)
        torch.testing.assert_close(got, want, rtol=1e-12, atol=0)
    w[:, 2] = 0.0
    moved = Y.clone()
    moved[2] += 5.0
    assert leg(X, moved, l, 0.8, weight=w).item() == pytest.approx(leg(X, Y, l, 0.8, weight=w).item(),
                                                                   rel=1e-12)


def test_leg_auto_is_dense_up_to_the_threshold_and_chunked_above(monkeypatch):
    leg_module = importlib.import_module("pcgeom.losses.leg")

    X, Y, l = (_t(a) for a in _leg_problem(43, n=10))
    calls = []
    monkeypatch.setitem(leg_module.LEG_BACKENDS, "dense",
                        lambda *a, **kw: calls.append("dense") or leg_dense(*a, **kw))
    monkeypatch.setitem(leg_module.LEG_BACKENDS, "chunked",
                        lambda *a, **kw: calls.append("chunked") or leg_chunked(*a, **kw))
    monkeypatch.setattr(leg_module, "DENSE_MAX_PAIRS", 100)
    leg(X, Y, l, 0.8)
    monkeypatch.setattr(leg_module, "DENSE_MAX_PAIRS", 99)
    leg(X, Y, l, 0.8)
    assert calls == ["dense", "chunked"]
    assert leg_module.DENSE_MAX_PAIRS == 99 and 5809**2 <= 1 << 26  # the paper's stages stay dense


def test_gradcheck_leg_chunked():
    X, Y, l = _leg_problem(44, n=6)
    X, Y, l = _t(X), _t(Y).requires_grad_(True), _t(l).requires_grad_(True)
    w = _t(_rng(45).uniform(size=(6, 6)) > 0.4)
    assert torch.autograd.gradcheck(lambda y, li: leg_chunked(X, y, li, 1.5, block=4), (Y, l))
    assert torch.autograd.gradcheck(lambda y, li: leg_chunked(X, y, li, 1.5, weight=w, block=4),
                                    (Y, l))


def _hand_problem(seed: int, n: int = 23, m: int = 31):
    rng = _rng(seed)
    return _t(rng.uniform(-1, 1, size=(n, 2))), _t(rng.uniform(-1, 1, size=(m, 2)))


@pytest.mark.parametrize("alpha", [2.0, 20.0, 100.0])
@pytest.mark.parametrize("block", [1, 4, 23])
def test_hand_chunked_equals_dense_value_and_gradients(alpha, block):
    Y, W = _hand_problem(46)
    want = _value_and_grads(lambda y, w: hand_dense(y, w, alpha), Y, W)
    got = _value_and_grads(lambda y, w: hand_chunked(y, w, alpha, block=block), Y, W)
    _assert_same_value_and_grads(got, want, rtol=1e-10, atol=1e-12)


def test_hand_chunked_is_stable_where_a_block_is_far_from_every_target():
    # alpha * d of about 2000: an unshifted exp(-alpha d) underflows to 0 in every block
    Y, W = _hand_problem(47)
    Y = Y + 20.0
    want = _value_and_grads(lambda y: hand_dense(y, W, 100.0), Y)
    got = _value_and_grads(lambda y: hand_chunked(y, W, 100.0, block=5), Y)
    assert torch.isfinite(got[0]) and torch.isfinite(got[1]).all()
    _assert_same_value_and_grads(got, want, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("alpha", [2.0, 20.0, 100.0])
def test_hand_knn_with_all_candidates_equals_dense(alpha):
    Y, W = _hand_problem(48)
    want = _value_and_grads(lambda y, w: hand_dense(y, w, alpha), Y, W)
    for k in (31, 100):  # k = M (> N), and k beyond both sizes (clamped)
        got = _value_and_grads(lambda y, w: hand_knn(y, w, alpha, k=k), Y, W)
        _assert_same_value_and_grads(got, want, rtol=1e-12, atol=1e-14)


def test_hand_knn_with_few_neighbours_is_close_to_dense_at_large_alpha():
    # A mapped cloud and a domain sample like a refinement step's, scaled down (spacing of W
    # about 0.12).
    rng = _rng(49)
    Y = _t(rng.uniform(-1, 1, size=(600, 2)))
    W = _t(rng.uniform(-1, 1, size=(256, 2)))

    def errors(alpha, k):
        want = _value_and_grads(lambda y: hand_dense(y, W, alpha), Y)
        got = _value_and_grads(lambda y: hand_knn(y, W, alpha, k=k), Y)
        return (abs(got[0].item() - want[0].item()) / want[0].item(),
                ((got[1] - want[1]).norm() / want[1].norm()).item())

    # Measured (value, gradient relative errors): alpha 100: k=4 (5e-4, 3e-2),
    # k=8 (4e-4, 3e-3), k=16 (2e-5, 2e-4); alpha 20, k=8: (0.19, 0.35).
    at100 = {k: errors(100.0, k) for k in (4, 8, 16)}
    assert at100[8][0] < 1e-3 and at100[8][1] < 1e-2
    assert at100[16][0] < at100[8][0] < at100[4][0] and at100[16][1] < at100[8][1] < at100[4][1]
    assert errors(20.0, 8)[0] > 10 * at100[8][0]  # an approximation that needs a sharp alpha


def test_hand_auto_is_dense_up_to_the_threshold_and_chunked_above(monkeypatch):
    hand_module = importlib.import_module("pcgeom.losses.hand")

    Y, W = _hand_problem(50, n=5, m=6)
    calls = []
    monkeypatch.setitem(hand_module.HAND_BACKENDS, "dense",
                        lambda *a: calls.append("dense") or hand_dense(*a))
    monkeypatch.setitem(hand_module.HAND_BACKENDS, "chunked",
                        lambda *a: calls.append("chunked") or hand_chunked(*a))
    monkeypatch.setattr(hand_module, "DENSE_MAX_PAIRS", 30)
    hand(Y, W, 5.0)
    monkeypatch.setattr(hand_module, "DENSE_MAX_PAIRS", 29)
    hand(Y, W, 5.0)
    assert calls == ["dense", "chunked"]  # never knn unless asked
    assert hand(Y, W, 5.0, backend="knn", k=6).item() == pytest.approx(hand_dense(Y, W, 5.0).item(),
                                                                       rel=1e-12)


@pytest.mark.parametrize("k", [0, 2.5, True])
def test_hand_knn_rejects_a_bad_k(k):
    Y, W = _hand_problem(51, n=5, m=6)
    with pytest.raises(ValueError, match=r"^hand: the 'knn' backend needs an int k >= 1, got "):
        hand(Y, W, 5.0, backend="knn", k=k)


def test_gradcheck_hand_chunked_and_knn():
    Y, W = _hand_problem(52, n=6, m=9)
    Y, W = Y.requires_grad_(True), W.requires_grad_(True)
    assert torch.autograd.gradcheck(lambda y, w: hand_chunked(y, w, 5.0, block=4), (Y, W))
    assert torch.autograd.gradcheck(lambda y, w: hand_knn(y, w, 5.0, k=3), (Y, W))


# =========================================================================== #
# 4. Theorem 2 (paper, "LDDE > angle distortion") on a small mesh
# =========================================================================== #
def _grid_mesh(n: int = 6):
    u = np.linspace(0.0, 1.0, n)
    xx, yy = np.meshgrid(u, u, indexing="ij")
    P = np.c_[xx.ravel(), yy.ravel()]
    V = np.c_[P, 0.1 * np.sin(P[:, 0]) * np.cos(P[:, 1])]
    F = []
    for a in range(n - 1):
        for b in range(n - 1):
            v00, v01, v10, v11 = a * n + b, a * n + b + 1, (a + 1) * n + b, (a + 1) * n + b + 1
            F += [[v00, v10, v11], [v00, v11, v01]]
    return V, np.asarray(F, dtype=np.int64)


def _angles(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Interior angles, column c at vertex F[:, c]."""
    out = np.empty(F.shape, dtype=np.float64)
    for c in range(3):
        a, b, o = V[F[:, c]], V[F[:, (c + 1) % 3]], V[F[:, (c + 2) % 3]]
        u, w = b - a, o - a
        cos = (u * w).sum(1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
        out[:, c] = np.arccos(np.clip(cos, -1.0, 1.0))
    return out


def _theorem2_setup():
    V, F = _grid_mesh(6)
    P = V[:, :2]
    # smooth, nearly conformal map: the xy projection, slightly perturbed
    Y = P + 0.03 * np.c_[np.sin(2.0 * P[:, 1]), np.cos(1.5 * P[:, 0]) * P[:, 0]]
    # l from a smooth function, close to the true 1 / (2 lambda) ~ 1/2
    lam_inv = 0.5 + 0.02 * np.cos(P[:, 0] + 0.5 * P[:, 1])
    edges = np.unique(np.sort(np.r_[F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=1), axis=0)
    return V, F, Y, lam_inv, edges


def _lam(lam_inv, i, j):
    return 1.0 / (lam_inv[i] + lam_inv[j])


@pytest.mark.parametrize("sigma_factor", [1.0, 0.7, 2.5])
def test_theorem2_leg_bounds_angle_distortion(sigma_factor):
    import igl  # only the tests use libigl here

    V, F, Y, l, edges = _theorem2_setup()
    N = len(V)
    ei, ej = edges[:, 0], edges[:, 1]
    dx = np.linalg.norm(V[ei] - V[ej], axis=1)
    dy = np.linalg.norm(Y[ei] - Y[ej], axis=1)
    R = dx.max()
    r_f = np.max(np.abs((dy / dx) / _lam(l, ei, ej) - 1.0))
    r_s = 0.0
    for tri in F:
        for a in range(3):
            for b in range(3):
                for c in range(3):
                    if len({a, b, c}) == 3:  # lambda_ik / lambda_ij - 1 over ordered edge pairs
                        i, j, k = tri[a], tri[b], tri[c]
                        r_s = max(r_s, abs(_lam(l, i, k) / _lam(l, i, j) - 1.0))
    assert 0.0 < r_f < 1.0 and 0.0 < r_s < 1.0

    # angles: libigl on the 3D surface and the planar image, cross-checked by hand
    theta = igl.internal_angles(V, F)
    phi = igl.internal_angles(np.c_[Y, np.zeros(N)], F)
    np.testing.assert_allclose(theta, _angles(V, F), atol=1e-12)
    np.testing.assert_allclose(phi, _angles(np.c_[Y, np.zeros(N)], F), atol=1e-12)
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)  # A_T of the 3D triangles
    rhs = 4.0 / math.pi**2 / N**2 * np.sum(area**2 * ((theta - phi) ** 2).sum(axis=1))
    assert rhs > 0.0  # the map does distort angles

    sigma = sigma_factor * (1.0 + r_f) * R
    D = leg(_t(V), _t(Y), _t(l), sigma).item()
    coef = (sigma**2 * math.exp((1.0 + r_f) ** 2 * R**2 / sigma**2)) ** 2
    lhs = coef * D + 162.0 * len(F) / N**2 * R**4 * (r_s + r_f)
    assert lhs >= rhs

    # The C term alone dominates the theorem on such meshes, so also check the
    # proof's LEG-dependent steps, which a wrong LEG would break:
    # (a) mean value step, per edge: D_ij >= (dx^2 - dy^2/lam^2)^2 eta^4 e^{-2 eta^2 (1+r_f)^2 dx^2}
    D_edges = np.array([
        leg_pairs(_t(V), _t(Y), _t(l), sigma, torch.tensor([a]), torch.tensor([b])).item()
        for a, b in edges
    ])
    eta2 = 1.0 / sigma**2
    q = dx**2 - dy**2 / _lam(l, ei, ej) ** 2
    mvt = q**2 * eta2**2 * np.exp(-2.0 * eta2 * (1.0 + r_f) ** 2 * dx**2)
    assert np.all(D_edges >= mvt * (1.0 - 1e-9))
    assert np.all(D_edges <= q**2 * eta2**2 * (1.0 + 1e-9))  # e^{-c} <= 1 on the other side
    # (b) summed over triangles: E^2 D_sigma >= 1/(4 N^2) sum_T sum_n (D^T_n)^2,
    #     with E = e^{eta^2 (1+r_f)^2 R^2} / eta^2 (each edge in <= 2 triangles,
    #     and D_sigma counts each edge twice as an ordered pair)
    chain = 0.0
    for tri in F:
        sq = [
            np.sum((V[a] - V[b]) ** 2) - np.sum((Y[a] - Y[b]) ** 2) / _lam(l, a, b) ** 2
            for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0]))
        ]
        for n in range(3):
            chain += (sq[n] + sq[(n + 1) % 3] - sq[(n + 2) % 3]) ** 2
    chain /= 4.0 * N**2
    assert chain > 0.0
    assert coef * D >= chain


# =========================================================================== #
# 5. Gradients (float64 gradcheck)
# =========================================================================== #
@pytest.mark.parametrize("alpha", [-7.0, -0.5, 0.5, 7.0])
def test_gradcheck_boltzmann(alpha):
    x = _t(_rng(50).normal(size=(4, 6))).requires_grad_(True)
    assert torch.autograd.gradcheck(lambda t: boltzmann(t, alpha, dim=1), (x,))
    assert torch.autograd.gradcheck(lambda t: boltzmann(t, alpha, dim=0), (x,))


def test_gradcheck_hand():
    rng = _rng(51)
    Y = _t(rng.uniform(size=(6, 2))).requires_grad_(True)
    W = _t(rng.uniform(size=(9, 2)))
    assert torch.autograd.gradcheck(lambda y: hand(y, W, 5.0), (Y,))
    assert torch.autograd.gradcheck(lambda y, w: hand(y, w, 5.0),
                                    (Y, W.clone().requires_grad_(True)))


def test_gradcheck_leg_and_leg_pairs():
    X, Y, l = _leg_problem(52, n=6)
    X = _t(X)
    Y = _t(Y).requires_grad_(True)
    l = _t(l).requires_grad_(True)
    assert torch.autograd.gradcheck(lambda y, li: leg(X, y, li, 1.5), (Y, l))
    rng = _rng(53)
    i, j = torch.from_numpy(rng.integers(0, 6, 15)), torch.from_numpy(rng.integers(0, 6, 15))
    w = _t(rng.uniform(0.1, 2.0, 15))
    assert torch.autograd.gradcheck(lambda y, li: leg_pairs(X, y, li, 1.5, i, j), (Y, l))
    assert torch.autograd.gradcheck(lambda y, li: leg_pairs(X, y, li, 1.5, i, j, weight=w), (Y, l))


def test_gradcheck_landmark_hand():
    rng = _rng(54)
    P1 = _t(rng.uniform(size=(4, 2))).requires_grad_(True)
    P2 = _t(rng.uniform(size=(3, 2))).requires_grad_(True)
    Q1, Q2 = _t(rng.uniform(size=(7, 2))), _t(rng.uniform(size=(2, 2)))
    assert torch.autograd.gradcheck(lambda a, b: landmark_hand([a, b], [Q1, Q2], 5.0), (P1, P2))


# =========================================================================== #
# 6. landmark HAND
# =========================================================================== #
def test_landmark_hand_is_the_sum_of_hand_over_pairs():
    rng = _rng(60)
    mapped = [_t(rng.uniform(size=(n, 2))) for n in (3, 11, 6)]
    targets = [_t(rng.uniform(size=(m, 2))) for m in (8, 4, 6)]  # unequal sizes
    got = landmark_hand(mapped, targets, 12.0)
    want = sum(hand(p, q, 12.0).item() for p, q in zip(mapped, targets))
    assert got.shape == ()
    assert math.isclose(got.item(), want, rel_tol=1e-13)
    # one pair is plain HAND
    assert landmark_hand(mapped[:1], targets[:1], 12.0).item() == pytest.approx(
        hand(mapped[0], targets[0], 12.0).item(), rel=1e-14
    )


def test_landmark_hand_rejects_mismatched_lengths():
    a = _t(np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"got 2 landmark sets but 1 target sets"):
        landmark_hand([a, a], [a], 5.0)


def test_landmark_hand_rejects_empty_lists():
    with pytest.raises(ValueError, match=r"at least one landmark pair"):
        landmark_hand([], [], 5.0)
