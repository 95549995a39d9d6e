"""The shared sparse factorization: cholespy's Cholesky against SuperLU, the fallbacks."""

from __future__ import annotations

import builtins

import numpy as np
import pytest
import scipy.sparse as sp

from pcgeom.maps import _sparse
from pcgeom.maps._sparse import solver_name, spd_factor


def _laplacian(n: int = 30, shift: float = 1e-3) -> sp.csr_matrix:
    """The 5-point Laplacian of an n x n grid plus ``shift`` I: positive definite."""
    T = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    return (sp.kron(T, sp.identity(n)) + sp.kron(sp.identity(n), T)
            + shift * sp.identity(n * n)).tocsr()


def test_cholespy_and_superlu_solve_the_same_system():
    pytest.importorskip("cholespy")
    A = _laplacian()
    b = np.random.default_rng(0).normal(size=(A.shape[0], 2))
    x_chol = spd_factor(A, solver="cholespy")(b)
    assert solver_name() == "cholespy"
    x_lu = spd_factor(A, solver="superlu")(b)
    assert solver_name() == "superlu"
    assert np.abs(A @ x_chol - b).max() < 1e-9
    np.testing.assert_allclose(x_chol, x_lu, rtol=1e-8, atol=1e-10)
    # One right-hand side, and duplicate COO entries summed as scipy does.
    coo = A.tocoo()
    doubled = sp.coo_matrix((np.concatenate([coo.data, coo.data]) / 2,
                             (np.concatenate([coo.row, coo.row]),
                              np.concatenate([coo.col, coo.col]))), shape=A.shape)
    np.testing.assert_allclose(spd_factor(doubled)(b[:, 0]), x_lu[:, 0], rtol=1e-8,
                               atol=1e-10)


def test_missing_cholespy_falls_back_to_superlu_with_one_notice(monkeypatch):
    real_import = builtins.__import__

    def no_cholespy(name, *args, **kwargs):
        if name == "cholespy":
            raise ImportError("No module named 'cholespy'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_cholespy)
    monkeypatch.setitem(_sparse._state, "noticed", False)
    A = _laplacian(10)
    b = np.ones(A.shape[0])
    with pytest.warns(UserWarning, match=r"^cholespy is not available .*SuperLU") as caught:
        x = spd_factor(A)(b)
        spd_factor(A)(b)  # the notice is given once
    assert len([w for w in caught if "cholespy" in str(w.message)]) == 1
    assert "\n" not in str(caught[0].message)
    assert solver_name() == "superlu" and np.abs(A @ x - b).max() < 1e-9
    with pytest.raises(ValueError, match="solver 'cholespy': cholespy is not installed"):
        spd_factor(A, solver="cholespy")


def test_a_matrix_not_positive_definite_is_solved_by_lu():
    pytest.importorskip("cholespy")
    A = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))  # eigenvalues 3 and -1
    x = spd_factor(A)(np.array([3.0, 3.0]))
    assert solver_name() == "superlu"
    np.testing.assert_allclose(x, [1.0, 1.0])
    with pytest.raises(ValueError, match="not positive definite"):
        spd_factor(A, solver="cholespy")
    with pytest.raises(ValueError, match="solver: expected 'auto' or one of"):
        spd_factor(A, solver="cholmod")
