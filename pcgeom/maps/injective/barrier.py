"""Step 4: the barrier descent (:func:`_descend`), projected Newton or L-BFGS under the
feasible line search, loops sliding on their rings; optionally every quad kept convex."""

from __future__ import annotations

import math

import numpy as np

from ...config import BarrierConfig
from ...mesh import half_edges, opposite_corners, signed_areas
from .energies import _barrier, _barrier_hessian
from .jacobians import (_det_cof, _jacobian_matrices, _jacobians, _scatter, flipped,
                        reference_triangles)
from .linesearch import max_feasible_step
from .._sparse import SymbolicCache
from .newton import _Assembly, _lbfgs_direction, _newton_factor
from .rings import _Layout


def _descend(V: np.ndarray, F: np.ndarray, layout: _Layout, config: BarrierConfig,
             area_G: tuple[np.ndarray, np.ndarray], *, pull=None, cover=None, outside=None
             ) -> tuple[np.ndarray, dict]:
    """Step 4 on the variables of ``layout``: the barrier energy, every step short of a zero
    area and accepted only when the loops stay in order. ``area_G``: the weighted reference
    areas and ``G`` of ``F``.

    ``pull = (index, targets, weight)`` adds ``weight mean_i |u_i - q_i|^2 / A`` for the
    vertices ``index``; ``cover = (loops, ring areas)`` the uncovered area
    (:attr:`BarrierConfig.cover`); ``outside = (index, region)`` ``cover sum_i d_i^2 / A``,
    ``d_i`` the distance of vertex ``index[i]`` to the shapely ``region`` (0 inside)."""
    import scipy.sparse as sp
    import shapely

    n = len(V)
    z = layout.z0.copy()
    W, frames = layout.unpack(z)
    area, G = area_G
    total = float(area.sum())
    m = len(F)
    if config.flip_guard > 0:
        # Each interior edge's other diagonal, where the start has it positive: the quads of
        # two triangles stay convex. Not those nearly flat at the start (three vertices on
        # one straight side of a ring stay flat): det J > 1e-4.
        alt = _other_diagonals(F)
        alt_area, alt_G = reference_triangles(V, alt, check=False)
        scale = math.sqrt(float(reference_triangles(V, F, check=False)[0].sum()) / total)
        keep = signed_areas(W, alt) > 1e-4 * alt_area / scale ** 2
        F = np.vstack([F, alt[keep]])
        area = np.concatenate([area, config.flip_guard * alt_area[keep] / scale ** 2])
        G = np.concatenate([G, alt_G[keep] * scale])

    def fun(z):
        W, frames = layout.unpack(z)
        value, dJ = _barrier(_jacobians(W, F, G), area, config.energy, config.power,
                             config.blend)
        if not math.isfinite(value):
            return value, None, W, frames, None
        value /= total
        gU = _scatter(dJ, F, G, n) / total
        if pull is not None:
            index, targets, weight = pull
            r = W[index] - targets
            c = weight / (len(index) * total)
            value += c * float((r ** 2).sum())
            np.add.at(gU, index, 2.0 * c * r)
        if cover is not None:
            c = config.cover / total
            for loop, ring_area in zip(*cover):
                P = W[loop]
                nxt, prv = np.roll(P, -1, axis=0), np.roll(P, 1, axis=0)
                S = 0.5 * float((P[:, 0] * nxt[:, 1] - P[:, 1] * nxt[:, 0]).sum())
                sign = 1.0 if ring_area > 0 else -1.0
                value += c * sign * (ring_area - S)
                # dS/du_i = (y_(i+1) - y_(i-1), x_(i-1) - x_(i+1)) / 2 (the shoelace)
                dS = 0.5 * np.column_stack([nxt[:, 1] - prv[:, 1], prv[:, 0] - nxt[:, 0]])
                np.add.at(gU, loop, -c * sign * dS)
        if outside is not None:
            index, region = outside
            P = W[index]
            out = ~shapely.contains_xy(region, P[:, 0], P[:, 1])
            if out.any():
                near = shapely.get_coordinates(shapely.shortest_line(
                    region.boundary, shapely.points(P[out])))[1::2]  # (k, 2) on the boundary
                r = P[out] - near
                c = config.cover / total
                value += c * float((r ** 2).sum())
                np.add.at(gU, index[out], 2.0 * c * r)
        return value, layout.pull(gU, frames), W, frames, gU

    assemble, B = _Assembly(F, n), _jacobian_matrices(G)

    def hessian(W, frames, gU):
        # The uncovered area's Hessian is indefinite and left out (a Gauss-Newton model).
        H4 = _barrier_hessian(_jacobians(W, F, G), area, config.energy, config.power,
                              config.blend) / total
        H = assemble(H4, B)
        if pull is not None:
            index, _, weight = pull
            diag = np.zeros(2 * n)
            np.add.at(diag, 2 * index, 2.0 * weight / (len(index) * total))
            np.add.at(diag, 2 * index + 1, 2.0 * weight / (len(index) * total))
            H = H + sp.diags(diag)
        if outside is not None:
            index, _ = outside
            diag = np.zeros(2 * n)
            diag[2 * index] = diag[2 * index + 1] = 2.0 * config.cover / total
            H = H + sp.diags(diag)
        P = layout.matrix(frames)
        return (P.T @ H @ P + sp.diags(layout.curvature(gU, frames))).tocsr()

    newton = config.method == "newton"
    E, g, W, frames, gU = fun(z)
    if not math.isfinite(E):
        raise ValueError("a folded or flat triangle where the barrier starts")
    E_start = E
    S, Y = [], []
    history = [E]
    evaluations, it, steps_cut = 1, 0, 0
    solve, age = None, 0
    cache = SymbolicCache()  # the Hessians share their pattern: CHOLMOD analyses it once
    for it in range(1, config.iterations + 1):
        if newton:
            if solve is None or age >= config.refactor:
                solve, age = _newton_factor(hessian(W, frames, gU), cache), 0
            d, age = -solve(g), age + 1
        else:
            d = _lbfgs_direction(g, S, Y)
        if not float(g @ d) < 0 or (not newton and not S):
            if not float(g @ d) < 0:  # not a descent direction: restart from the gradient
                S, Y = [], []
                d = -g
            # A first step of 1e-3 of the map's size, where no curvature is known yet.
            d = d * (1e-3 * math.sqrt(total) / max(np.abs(d).max(), 1e-300))
        slope = float(g @ d)
        amax = max_feasible_step(W, F, layout.push(d, frames))
        a = min(1.0, config.max_fraction * amax)
        steps_cut += amax <= 1.0
        accepted = False
        for _ in range(60):
            z_new = z + a * d
            if layout.in_order(z_new):
                E_new, g_new, W_new, frames_new, gU_new = fun(z_new)
                evaluations += 1
                if math.isfinite(E_new) and E_new <= E + 1e-4 * a * slope:
                    accepted = True
                    break
            a *= 0.5
        if not accepted:
            if newton and age > 1:  # a Hessian some steps old: try the current one
                solve = None
                continue
            break
        s, y = z_new - z, g_new - g
        if s @ y > 1e-12 * math.sqrt((s @ s) * (y @ y)):
            S.append(s)
            Y.append(y)
            if len(S) > config.memory:
                S.pop(0)
                Y.pop(0)
        z, E, g, W, frames, gU = z_new, E_new, g_new, W_new, frames_new, gU_new
        history.append(E)
        if it >= config.patience and history[-config.patience - 1] - E < config.tolerance * E:
            break
    det = _det_cof(_jacobians(W, F, G))[0][:m]
    info = {"energy": config.energy, "energy_start": E_start, "energy_end": E,
            "iterations": it, "evaluations": evaluations, "steps_cut": int(steps_cut),
            "min_det": float(det.min()), "min_area": float(signed_areas(W, F[:m]).min()),
            "flipped": flipped(W, F[:m]), "in_order": layout.in_order(z),
            "guarded_quads": len(F) - m, "history": history[::10]}
    at, info["t"] = layout.nf, []
    for loop in layout.loops:  # where each sliding vertex ended, along its ring
        info["t"].append(z[at:at + len(loop)].copy())
        at += len(loop)
    return W, info


def _other_diagonals(F: np.ndarray) -> np.ndarray:
    """For each interior edge ``ab`` of ``F`` (triangles ``abc`` and ``bad``), the two
    triangles of its quad split by the other diagonal, ``adc`` and ``dbc`` (oriented as
    ``F``), (2e, 3)."""
    e = half_edges(F)
    opposite = opposite_corners(F)
    n = int(F.max()) + 1
    code = e[:, 0] * n + e[:, 1]
    order = np.argsort(code)
    twin = np.searchsorted(code[order], e[:, 1] * n + e[:, 0])
    twin = np.clip(twin, 0, len(e) - 1)
    found = code[order][twin] == e[:, 1] * n + e[:, 0]
    i = np.flatnonzero(found & (e[:, 0] < e[:, 1]))
    j = order[twin[i]]
    a, b, c, d = e[i, 0], e[i, 1], opposite[i], opposite[j]
    ok = c != d
    a, b, c, d = a[ok], b[ok], c[ok], d[ok]
    return np.vstack([np.column_stack([a, d, c]), np.column_stack([d, b, c])])
