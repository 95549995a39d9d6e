"""The sparse solves the maps share: one factorization of a symmetric positive definite
system, used by LSCM, the disk map's Green's function and the harmonic layouts."""

from __future__ import annotations

__all__ = ["spd_factor"]


def spd_factor(A):
    """A sparse LU of the symmetric positive definite ``A`` (scipy's SuperLU), ordered for
    symmetry: minimum degree on ``A^T + A`` and no pivoting, which a positive definite matrix
    does not need. Returns the factor's ``solve``.

    SuperLU's default (COLAMD, partial pivoting) is made for unsymmetric matrices: on the LSCM
    system of a 100k-point height field it filled 37.1M entries and took 23 s; this ordering
    fills 14.7M in 8.7 s, with the same solution to 2e-8 (benchmarks, 2 cores).
    """
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    return splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                options={"SymmetricMode": True}).solve
