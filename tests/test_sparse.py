"""The shared sparse factorization: CHOLMOD (cvxopt) and cholespy against SuperLU, the
fallbacks."""

from __future__ import annotations

import builtins

import numpy as np
import pytest
import scipy.sparse as sp

from pcgeom.maps import _sparse
from pcgeom.maps._sparse import SymbolicCache, solver_name, spd_factor


def _laplacian(n: int = 30, shift: float = 1e-3) -> sp.csr_matrix:
    """The 5-point Laplacian of an n x n grid plus ``shift`` I: positive definite."""
    T = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    return (sp.kron(T, sp.identity(n)) + sp.kron(sp.identity(n), T)
            + shift * sp.identity(n * n)).tocsr()


def _hide(monkeypatch, *modules):
    """Make ``import`` of ``modules`` fail, as on a machine without them."""
    real_import = builtins.__import__

    def without(name, *args, **kwargs):
        if name.split(".")[0] in modules:
            raise ImportError(f"No module named {name!r}")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", without)
    monkeypatch.setitem(_sparse._state, "noticed", False)


@pytest.mark.parametrize("solver", ["cholmod", "cholespy"])
def test_each_cholesky_solves_the_system_superlu_solves(solver):
    pytest.importorskip(_sparse._MODULES[solver])
    A = _laplacian()
    b = np.random.default_rng(0).normal(size=(A.shape[0], 2))
    x_chol = spd_factor(A, solver=solver)(b)
    assert solver_name() == solver
    x_lu = spd_factor(A, solver="superlu")(b)
    assert solver_name() == "superlu"
    assert x_chol.shape == b.shape and np.abs(A @ x_chol - b).max() < 1e-9
    np.testing.assert_allclose(x_chol, x_lu, rtol=1e-8, atol=1e-10)
    # One right-hand side, and duplicate COO entries summed as scipy does.
    coo = A.tocoo()
    doubled = sp.coo_matrix((np.concatenate([coo.data, coo.data]) / 2,
                             (np.concatenate([coo.row, coo.row]),
                              np.concatenate([coo.col, coo.col]))), shape=A.shape)
    x_one = spd_factor(doubled, solver=solver)(b[:, 0])
    assert x_one.shape == (A.shape[0],)
    np.testing.assert_allclose(x_one, x_lu[:, 0], rtol=1e-8, atol=1e-10)


def test_auto_prefers_cholmod_and_leaves_cvxopt_options_as_they_were(monkeypatch):
    cholmod = pytest.importorskip("cvxopt.cholmod")
    monkeypatch.setattr(cholmod, "options", {"supernodal": 0})
    A = _laplacian(10)
    x = spd_factor(A)(np.ones(A.shape[0]))
    assert solver_name() == "cholmod" and np.abs(A @ x - 1.0).max() < 1e-9
    assert cholmod.options == {"supernodal": 0}


def test_missing_cvxopt_falls_back_to_cholespy_with_one_notice(monkeypatch):
    pytest.importorskip("cholespy")
    _hide(monkeypatch, "cvxopt")
    A = _laplacian(10)
    b = np.ones(A.shape[0])
    with pytest.warns(UserWarning, match=r"^cvxopt not available: .* with cholespy") as caught:
        x = spd_factor(A)(b)
        spd_factor(A)(b)  # the notice is given once
    assert len(caught) == 1 and "\n" not in str(caught[0].message)
    assert solver_name() == "cholespy" and np.abs(A @ x - b).max() < 1e-9
    with pytest.raises(ValueError, match="solver 'cholmod': cvxopt is not installed"):
        spd_factor(A, solver="cholmod")


def test_missing_choleskys_fall_back_to_superlu_with_one_notice(monkeypatch):
    _hide(monkeypatch, "cvxopt", "cholespy")
    A = _laplacian(10)
    b = np.ones(A.shape[0])
    with pytest.warns(UserWarning, match=r"^cvxopt and cholespy not available: .*SuperLU"
                      ) as caught:
        x = spd_factor(A)(b)
        spd_factor(A)(b)
    assert len(caught) == 1 and "\n" not in str(caught[0].message)
    assert solver_name() == "superlu" and np.abs(A @ x - b).max() < 1e-9
    with pytest.raises(ValueError, match="solver 'cholespy': cholespy is not installed"):
        spd_factor(A, solver="cholespy")


@pytest.mark.parametrize("solver", ["cholmod", "cholespy"])
def test_a_matrix_not_positive_definite_is_solved_by_lu(solver):
    pytest.importorskip(_sparse._MODULES[solver])
    A = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))  # eigenvalues 3 and -1
    x = spd_factor(A)(np.array([3.0, 3.0]))
    assert solver_name() == "superlu"
    np.testing.assert_allclose(x, [1.0, 1.0])
    with pytest.raises(ValueError, match=f"solver '{solver}': the matrix is not positive"):
        spd_factor(A, solver=solver)
    with pytest.raises(ValueError, match="solver: expected 'auto' or one of"):
        spd_factor(A, solver="pardiso")


def test_metis_order_keeps_each_vertex_together_and_the_solution(monkeypatch):
    pytest.importorskip("pymetis")
    pytest.importorskip("cvxopt")
    from pcgeom.maps._sparse import fill_order, ordering_name

    n = 20
    graph = _laplacian(n)  # the vertices' grid graph
    # Two unknowns per vertex (as LSCM's u and v), two of them pinned (no unknown).
    unknown = np.arange(2 * n * n).reshape(2, n * n).T.copy()
    unknown[[0, 7], 1] = -1
    free = unknown[unknown >= 0]
    unknown[unknown >= 0] = np.searchsorted(np.sort(free), unknown[unknown >= 0])
    assert fill_order(graph, unknown) is None  # small: CHOLMOD's own AMD orders it
    monkeypatch.setattr(_sparse, "METIS_UNKNOWNS", 0)
    order = fill_order(graph, unknown)
    assert np.array_equal(np.sort(order), np.arange(2 * n * n - 2))
    # A vertex's unknowns are eliminated one after the other.
    position = np.empty_like(order)
    position[order] = np.arange(len(order))
    both = (unknown >= 0).all(axis=1)
    assert (np.abs(position[unknown[both, 0]] - position[unknown[both, 1]]) == 1).all()
    A = sp.kron(graph, np.array([[2.0, 0.5], [0.5, 2.0]])).tocsr()
    keep = np.setdiff1d(np.arange(2 * n * n), [1, 15])  # interleaved: vertex v has 2v, 2v + 1
    A = A[keep][:, keep]
    b = np.random.default_rng(1).normal(size=A.shape[0])
    interleaved = np.full((n * n, 2), -1)
    interleaved[:, 0], interleaved[:, 1] = np.arange(0, 2 * n * n, 2), np.arange(1, 2 * n * n, 2)
    index = np.full(2 * n * n, -1)
    index[keep] = np.arange(len(keep))
    order = fill_order(graph, index[interleaved])
    x_metis = spd_factor(A, order=order)(b)
    assert solver_name() == "cholmod" and ordering_name() == "metis"
    x_amd = spd_factor(A)(b)
    assert ordering_name() == "amd"
    np.testing.assert_allclose(x_metis, x_amd, rtol=1e-9, atol=1e-12)


def test_missing_pymetis_leaves_the_order_to_cholmod(monkeypatch):
    from pcgeom.maps._sparse import fill_order

    _hide(monkeypatch, "pymetis")
    monkeypatch.setattr(_sparse, "METIS_UNKNOWNS", 0)
    assert fill_order(_laplacian(5), np.arange(25)[:, None]) is None


def test_a_failing_cholesky_gives_way_to_the_next_with_one_line(monkeypatch):
    pytest.importorskip("cvxopt")
    pytest.importorskip("cholespy")

    def broken(module, A, order=None, cache=None):
        raise ValueError("symbolic factorization failed\nsecond line")

    monkeypatch.setattr(_sparse, "_cholmod", broken)
    A = _laplacian(10)
    b = np.ones(A.shape[0])
    with pytest.warns(UserWarning, match=r"^cholmod failed on a system of 100 unknowns "
                      r"\(ValueError: symbolic factorization failed\); trying the next") as w:
        x = spd_factor(A)(b)
    assert "\n" not in str(w[0].message)
    assert solver_name() == "cholespy" and np.abs(A @ x - b).max() < 1e-9
    with pytest.raises(ValueError, match="symbolic factorization failed"):
        spd_factor(A, solver="cholmod")


def test_symbolic_cache_reuses_the_analysis_of_one_pattern_only(monkeypatch):
    cholmod = pytest.importorskip("cvxopt.cholmod")
    calls = []
    symbolic = cholmod.symbolic
    monkeypatch.setattr(cholmod, "symbolic", lambda *a, **k: calls.append(1) or symbolic(*a, **k))
    A = _laplacian(20)
    b = np.random.default_rng(1).normal(size=A.shape[0])
    cache = SymbolicCache()
    scaled = A.copy()
    scaled.data *= np.linspace(1.0, 3.0, len(scaled.data))
    scaled = (scaled + scaled.T).tocsr()  # the same pattern, other values
    for M in (A, scaled):  # the same solution bit for bit as a fresh analysis
        np.testing.assert_array_equal(spd_factor(M, cache=cache)(b), spd_factor(M)(b))
    assert cache.hits == 1 and len(calls) == 3
    denser = A + sp.diags([1e-3], [5], shape=A.shape) + sp.diags([1e-3], [-5], shape=A.shape)
    np.testing.assert_array_equal(spd_factor(denser, cache=cache)(b), spd_factor(denser)(b))
    assert cache.hits == 1 and len(calls) == 5  # another pattern: analysed again
    not_pd = -A
    assert spd_factor(not_pd, cache=cache) is not None and cache.key is None  # LU; forgotten
