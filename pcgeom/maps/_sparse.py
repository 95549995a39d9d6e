"""The sparse solves the maps share: one factorization of a symmetric positive definite
system, used by LSCM, the disk map's Green's function, the harmonic layouts and the injective
map's Newton steps.

A supernodal sparse Cholesky (cholespy, CHOLMOD inside) when it is installed, else scipy's
SuperLU ordered for symmetry. Measured on the Newton systems of the injective map of a
19.9k-point face onto the smile (40k unknowns, 266 factorizations, one thread): SuperLU
0.348 s each, 92 s of the map's 139 s.
"""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["spd_factor", "solver_name", "SOLVERS"]

SOLVERS = ("cholespy", "superlu")
"""The factorizations :func:`spd_factor` can use, preferred first."""

_state = {"noticed": False, "last": None}


def _cholespy():
    """The cholespy module, or None (with a one-line notice, once) when it cannot load."""
    try:
        import cholespy
    except ImportError as err:  # an optional speed-up: the map is the same without it
        if not _state["noticed"]:
            _state["noticed"] = True
            warnings.warn(f"cholespy is not available ({err}); sparse systems are solved "
                          "with scipy's SuperLU, several times slower "
                          "(pip install cholespy)", stacklevel=3)
        return None
    return cholespy


def solver_name() -> str | None:
    """Which factorization the last :func:`spd_factor` used (one of :data:`SOLVERS`), or
    None before the first."""
    return _state["last"]


def spd_factor(A, *, solver: str = "auto"):
    """Factor the symmetric positive definite sparse ``A`` once; returns ``solve(b)`` for
    ``b`` of shape (n,) or (n, k).

    ``solver``: ``"auto"`` (cholespy when it loads and the matrix is positive definite to
    its pivots, else SuperLU), ``"cholespy"`` or ``"superlu"``. SuperLU is ordered for
    symmetry: minimum degree on ``A^T + A`` and no pivoting, which a positive definite matrix
    does not need (its default, COLAMD with partial pivoting, filled 37.1M entries and took
    23 s on the LSCM system of a 100k-point height field; this ordering 14.7M in 8.7 s, the
    same solution to 2e-8).
    """
    import scipy.sparse as sp

    if solver not in ("auto", *SOLVERS):
        raise ValueError(f"solver: expected 'auto' or one of {', '.join(SOLVERS)}, "
                         f"got {solver!r}")
    A = sp.csc_matrix(A, dtype=np.float64)
    A.sum_duplicates()
    A.sort_indices()
    n = A.shape[0]
    cholespy = _cholespy() if solver in ("auto", "cholespy") and n > 0 else None
    if cholespy is not None:
        try:
            factor = cholespy.CholeskySolverD(n, A.indptr.astype(np.int32),
                                              A.indices.astype(np.int32), A.data,
                                              cholespy.MatrixType.CSC)
        except ValueError:  # not positive definite to rounding: LU still solves it
            if solver == "cholespy":
                raise
        else:
            _state["last"] = "cholespy"

            def solve(b):
                b = np.ascontiguousarray(b, dtype=np.float64)
                x = np.zeros_like(b)
                factor.solve(b, x)
                return x

            return solve
    elif solver == "cholespy":
        raise ValueError("solver 'cholespy': cholespy is not installed")
    from scipy.sparse.linalg import splu

    _state["last"] = "superlu"
    return splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                options={"SymmetricMode": True}).solve
