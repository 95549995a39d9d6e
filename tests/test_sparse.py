"""The shared sparse factorization: CHOLMOD (cvxopt) and cholespy against SuperLU, the
fallbacks."""

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


def test_auto_prefers_cholmod():
    pytest.importorskip("cvxopt")
    A = _laplacian(10)
    spd_factor(A)(np.ones(A.shape[0]))
    assert solver_name() == "cholmod"


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
