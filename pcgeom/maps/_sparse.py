"""The sparse solves the maps share: one factorization of a symmetric positive definite
system, used by LSCM, the disk map's Green's function, the harmonic layouts and the injective
map's Newton steps.

Preferred first, each when it loads:

1. **CHOLMOD** (SuiteSparse's supernodal Cholesky) through cvxopt, whose wheel carries
   CHOLMOD and an optimized BLAS. Measured on the LSCM system of a 300k-point jittered-grid
   height field (600k unknowns, 4.2M non-zeros, 2 cores): 2.4 s (ordering 0.7, factor 1.4).
2. **cholespy** (CHOLMOD too, but its wheel's reference BLAS makes the dense supernodes
   slow): 8.2 s on the same system; it has a CUDA build.
3. **SuperLU** (scipy) ordered for symmetry: 33 s on the same system.

A matrix that is not positive definite to its pivots is solved by SuperLU's LU.
"""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["spd_factor", "SymbolicCache", "solver_name", "ordering_name", "fill_order", "SOLVERS",
           "METIS_UNKNOWNS"]

SOLVERS = ("cholmod", "cholespy", "superlu")
"""The factorizations :func:`spd_factor` can use, preferred first."""

_MODULES = {"cholmod": "cvxopt", "cholespy": "cholespy"}
"""The package each optional factorization comes from."""

METIS_UNKNOWNS = 1_000_000
"""Systems with at least this many unknowns are ordered by METIS (:func:`fill_order`) when
pymetis is installed. Measured on the LSCM system of a 1M-point jittered-grid height field
(2M unknowns), against CHOLMOD's own AMD: the factor 1.4 GB instead of 2.2, the
factorization 7.6 s instead of 11.6 for 5.0 s of ordering; at 300k points (600k unknowns)
ordering, analysis and factorization 2.5 s instead of 1.9, where the factor's 0.1 GB matter
less."""

_state = {"noticed": False, "last": None, "ordering": None}


def _load(solver: str):
    """The module behind ``solver`` ("cholmod": cvxopt's, "cholespy"), or None."""
    try:
        if solver == "cholmod":
            import cvxopt
            import cvxopt.cholmod

            return cvxopt
        import cholespy

        return cholespy
    except (ImportError, OSError):  # not installed, or a binary that does not load
        return None


def _notice(missing: list[str], using: str) -> None:
    """One line, once a process, when the preferred factorization cannot load."""
    if not _state["noticed"]:
        _state["noticed"] = True
        packages = [_MODULES[s] for s in missing]
        warnings.warn(f"{' and '.join(packages)} not available: sparse systems are solved "
                      f"with {using}, several times slower (pip install {' '.join(packages)})",
                      stacklevel=4)


def solver_name() -> str | None:
    """Which factorization the last :func:`spd_factor` used (one of :data:`SOLVERS`), or
    None before the first."""
    return _state["last"]


def ordering_name() -> str | None:
    """The fill-reducing order of the last :func:`spd_factor`'s CHOLMOD: ``"metis"`` (given
    by :func:`fill_order`) or ``"amd"`` (its own); None for the other solvers, which order
    the matrix themselves."""
    return _state["ordering"]


def fill_order(graph, unknowns: np.ndarray) -> np.ndarray | None:
    """A fill-reducing order of a system's unknowns: METIS's nested dissection of the graph
    of its vertices, each vertex's unknowns kept together.

    Parameters
    ----------
    graph : (V, V) sparse
        The vertices' adjacency (its pattern is read; the diagonal is ignored).
    unknowns : (V, b) int
        The unknowns of each vertex (``-1``: none, as for a pinned value), numbered ``0 ..
        n - 1`` over all vertices.

    Returns
    -------
    (n,) int64 or None
        The unknowns in elimination order; None when the system has fewer than
        :data:`METIS_UNKNOWNS` unknowns or pymetis is not installed (CHOLMOD's AMD then
        orders it).
    """
    import scipy.sparse as sp

    unknowns = np.asarray(unknowns, dtype=np.int64).reshape(len(unknowns), -1)
    if (unknowns >= 0).sum() < METIS_UNKNOWNS:
        return None
    try:
        import pymetis
    except ImportError:
        return None
    G = sp.csr_matrix(graph, copy=True)
    G.setdiag(0)
    G.eliminate_zeros()
    G = (G + G.T).tocsr()  # METIS wants both directions of each edge
    G.sort_indices()
    options = pymetis.Options()
    options.niter = 1  # the same fill as its default 10 on meshes, 10% faster
    perm = np.asarray(pymetis.nested_dissection(
        pymetis.CSRAdjacency(G.indptr.astype(np.int32), G.indices.astype(np.int32)),
        options=options)[0], dtype=np.int64)
    order = unknowns[perm].ravel()
    return order[order >= 0]


class SymbolicCache:
    """CHOLMOD's symbolic analysis (ordering, elimination tree, supernodes) of the last
    matrix :func:`spd_factor` factored with it, reused for the next one with the same
    sparsity pattern and order, which is then only refactored numerically: the same factor
    to rounding, as the analysis reads the pattern only. For a sequence of systems of one
    pattern, such as the Newton steps of an optimization. Measured on the injective map's
    barrier of the three peaks (14k points, 4 landmarks): the analysis was 1.3 s of its
    Newton steps' 7 s.

    The factor is refactored in place: a ``solve`` that :func:`spd_factor` returned with
    this cache is only valid until its next call with it. Solvers other than CHOLMOD ignore
    it."""

    def __init__(self):
        self.key = None  # (indptr, indices, order) of the analysed lower triangle
        self.factor = None
        self.hits = 0
        """How many factorizations reused the analysis."""

    def lookup(self, lower, order):
        """The analysed factor for the pattern of ``lower`` (csc) and ``order``, or None."""
        if self.key is None:
            return None
        indptr, indices, known = self.key
        same_order = (known is None) == (order is None) and (
            order is None or np.array_equal(known, order))
        if (same_order and np.array_equal(indptr, lower.indptr)
                and np.array_equal(indices, lower.indices)):
            self.hits += 1
            return self.factor
        return None

    def store(self, lower, order, factor) -> None:
        """Keep ``factor``, the analysis of ``lower``'s pattern in ``order``."""
        self.key = (lower.indptr.copy(), lower.indices.copy(),
                    None if order is None else np.array(order, copy=True))
        self.factor = factor

    def clear(self) -> None:
        """Forget the analysis (after a factorization that failed)."""
        self.key = self.factor = None


def _cholmod(cvxopt, A, order=None, cache: SymbolicCache | None = None):
    """CHOLMOD's factor of ``A`` (its lower triangle) by cvxopt, in the elimination order
    ``order`` (else its own AMD), or None when it is not positive definite; the symbolic
    analysis from ``cache`` when it holds that of ``A``'s pattern."""
    import scipy.sparse as sp

    lower = sp.tril(A, format="csc")
    cols = np.repeat(np.arange(lower.shape[1], dtype=np.int64), np.diff(lower.indptr))
    M = cvxopt.spmatrix(cvxopt.matrix(lower.data), cvxopt.matrix(lower.indices.astype(np.int64)),
                        cvxopt.matrix(cols), lower.shape)
    del cols
    factor = None if cache is None else cache.lookup(lower, order)
    if factor is None:
        options = cvxopt.cholmod.options  # module-wide: CHOLMOD's defaults here, the caller's after
        saved = dict(options)
        options.clear()
        try:
            if order is not None:
                options["nmethods"] = 1  # the order given, not AMD's too (0.5 s at 300k points)
                factor = cvxopt.cholmod.symbolic(M, p=cvxopt.matrix(np.asarray(order, np.int64)))
            else:
                factor = cvxopt.cholmod.symbolic(M)
        finally:
            options.clear()
            options.update(saved)
        if cache is not None:
            cache.store(lower, order, factor)
    del lower
    try:
        cvxopt.cholmod.numeric(M, factor)
    except ArithmeticError:  # not positive definite
        if cache is not None:
            cache.clear()
        return None

    def solve(b):
        b = np.asarray(b, dtype=np.float64)
        B = cvxopt.matrix(np.asfortranarray(b.reshape(len(b), -1)))
        cvxopt.cholmod.solve(factor, B)
        return np.array(B).reshape(b.shape)

    return solve


def _cholespy(cholespy, A):
    """cholespy's factor of ``A``, or None when it is not positive definite."""
    try:
        factor = cholespy.CholeskySolverD(A.shape[0], A.indptr.astype(np.int32),
                                          A.indices.astype(np.int32), A.data,
                                          cholespy.MatrixType.CSC)
    except ValueError:  # not positive definite to rounding
        return None

    def solve(b):
        b = np.ascontiguousarray(b, dtype=np.float64)
        x = np.zeros_like(b)
        factor.solve(b, x)
        return x

    return solve


def spd_factor(A, *, solver: str = "auto", order: np.ndarray | None = None,
               cache: SymbolicCache | None = None):
    """Factor the symmetric positive definite sparse ``A`` once; returns ``solve(b)`` for
    ``b`` of shape (n,) or (n, k).

    ``order``: a fill-reducing permutation of the unknowns (:func:`fill_order`), used by
    CHOLMOD (the others order the matrix themselves).

    ``cache``: a :class:`SymbolicCache` whose CHOLMOD symbolic analysis is reused when ``A``
    has the pattern it analysed (else it analyses ``A`` and keeps that); the returned
    ``solve`` is then valid until the next call with the same cache.

    ``solver``: ``"auto"`` (the first of :data:`SOLVERS` that loads and factors, with a
    one-line warning for one that fails; SuperLU's LU when the matrix is not positive
    definite to its pivots), or one of :data:`SOLVERS` (a
    ``ValueError`` when it is not installed, or when a Cholesky meets a matrix that is not
    positive definite). SuperLU is ordered for symmetry: minimum degree on ``A^T + A`` and
    no pivoting, which a positive definite matrix does not need (its default, COLAMD with
    partial pivoting, filled 37.1M entries and took 23 s on the LSCM system of a 100k-point
    height field; this ordering 14.7M in 8.7 s, the same solution to 2e-8).
    """
    import scipy.sparse as sp

    if solver not in ("auto", *SOLVERS):
        raise ValueError(f"solver: expected 'auto' or one of {', '.join(SOLVERS)}, "
                         f"got {solver!r}")
    A = sp.csc_matrix(A, dtype=np.float64)
    A.sum_duplicates()
    A.sort_indices()
    tried = [s for s in SOLVERS[:-1] if solver in ("auto", s)]
    missing = []
    for name in tried if A.shape[0] > 0 else ():
        module = _load(name)
        if module is None:
            if solver == name:
                raise ValueError(f"solver {name!r}: {_MODULES[name]} is not installed")
            missing.append(name)
            continue
        try:
            solve = (_cholmod(module, A, order, cache) if name == "cholmod"
                     else _cholespy(module, A))
        except (ValueError, RuntimeError, MemoryError) as err:
            if cache is not None:
                cache.clear()
            if solver == name:
                raise
            # A solver that fails where it should not (its own bug, its memory): the next.
            why = (str(err).splitlines() or [""])[0]
            warnings.warn(f"{name} failed on a system of {A.shape[0]} unknowns "
                          f"({type(err).__name__}: {why}); trying the next solver",
                          stacklevel=2)
            continue
        if solve is None:
            if solver == name:
                raise ValueError(f"solver {name!r}: the matrix is not positive definite")
            break  # not positive definite: no other Cholesky will do better
        if missing:
            _notice(missing, name)
        _state["last"] = name
        _state["ordering"] = None
        if name == "cholmod":
            _state["ordering"] = "metis" if order is not None else "amd"
        return solve
    if missing and len(missing) == len(tried):
        _notice(missing, "scipy's SuperLU")
    from scipy.sparse.linalg import splu

    _state["last"] = "superlu"
    _state["ordering"] = None
    return splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                options={"SymmetricMode": True}).solve
