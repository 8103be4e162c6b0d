"""The delete-one-cluster jackknife covariance (CR3; MacKinnon, Nielsen & Webb 2023) of a least-squares fit, each
replicate one Gauss-Newton step from the solution: the one copy the output-error surge fit
(:mod:`boat_twin.ident.output_error`, clusters of consecutive time blocks) and the manoeuvring fit
(:mod:`boat_twin.ident.manoeuvring`, replay windows as clusters) share.

Unlike the plain sandwich (CR1), it carries the leverage of single clusters: a cluster that pulls the fit alone
moves its replicate by what dropping it would, not by its score over the whole fit's information."""

from __future__ import annotations

import numpy as np


def _unit_diagonal_scale(information: np.ndarray) -> np.ndarray:
    """(p,) 1/√I_kk (1 where I_kk is not positive): the scaling to a unit diagonal under which the pseudo-inverse's
    cut-off sees the information's structure, not its units (parameters in kg beside N·s/m)."""
    diagonal = np.diag(information)
    scale = np.ones_like(diagonal)
    scale[diagonal > 0.0] = diagonal[diagonal > 0.0] ** -0.5
    return scale


def cluster_rows(labels: np.ndarray) -> list[np.ndarray]:
    """Each cluster's row indices (in row order), clusters in label order: one sort, O(n log n) (a mask per
    cluster would be O(n·G))."""
    order = np.argsort(labels, kind="stable")
    bounds = np.append(np.unique(labels[order], return_index=True)[1], labels.size)
    return [order[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def cluster_squares(jac: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """(G, p, p) J_gᵀJ_g of each cluster's rows of ``jac`` (``labels`` (n,): the cluster of every row)."""
    return np.array([jac[rows].T @ jac[rows] for rows in cluster_rows(labels)])


def jackknife_shift(information: np.ndarray, cluster_squares: np.ndarray, cluster_score: np.ndarray) -> np.ndarray:
    """d_g = (I − J_gᵀJ_g)⁺·J_gᵀr_g, the step of the fit without cluster g, from the cluster's ``cluster_squares``
    J_gᵀJ_g (p, p) and ``cluster_score`` J_gᵀr_g (p,); ``information`` I (p, p): JᵀJ of all the rows (plus a
    penalty's). A caller that streams its rows sums I first and then each cluster's two. The pseudo-inverse is
    taken of the matrix scaled to a unit diagonal of I (parameters in kg beside N·s/m: unscaled, its condition
    number passes the pseudo-inverse's 1e-15 cut-off and rounding decides the spread)."""
    scale = _unit_diagonal_scale(information)
    without = (information - cluster_squares) * scale[:, None] * scale[None, :]
    return scale * (np.linalg.pinv(without) @ (scale * cluster_score))


def jackknife_spread(shifts: np.ndarray) -> np.ndarray:
    """(p, p) covariance (G − 1)/G·Σ_g (d_g − d̄)(d_g − d̄)ᵀ of the G clusters' shifts ``shifts`` (G, p)."""
    centred = shifts - shifts.mean(axis=0)
    return (shifts.shape[0] - 1) / max(shifts.shape[0], 1) * centred.T @ centred


def jackknife_covariance(jac: np.ndarray, residual: np.ndarray, labels: np.ndarray,
                         prior_information: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """(p, p) covariance of the fit with Jacobian ``jac`` (n, p) and residuals ``residual`` (n,) at its solution
    (:func:`jackknife_spread` of every cluster's :func:`jackknife_shift`, clusters the rows whose ``labels`` (n,)
    are equal); and G, the number of clusters. ``prior_information`` P (p, p; None: 0) is the information of
    penalty rows no cluster holds (a prior the fit minimised with the data's residuals), kept in every
    replicate: the spread is the data's alone, the caller adds the prior's own."""
    information = jac.T @ jac + (0.0 if prior_information is None else prior_information)
    clusters = cluster_rows(labels)
    shifts = np.array([jackknife_shift(information, jac[rows].T @ jac[rows], jac[rows].T @ residual[rows])
                       for rows in clusters])
    return jackknife_spread(shifts), len(clusters)


def cluster_degrees_of_freedom(information: np.ndarray, cluster_squares: np.ndarray) -> np.ndarray:
    """(p,) degrees of freedom of each coefficient's cluster-robust t statistic (Imbens & Kolesár 2016, the
    Bell-McCaffrey adjustment under a working model of independent unit-variance residuals), from the information
    I (p, p) and each cluster's J_gᵀJ_g ``cluster_squares`` (G, p, p): K = (Σλ)² / Σλ², λ the eigenvalues of GᵀG,
    G's column g the residual maker's cluster-g block times (I − H_gg)^(-1/2)·J_g·I⁻¹·e_k. Equal clusters give
    about G − 1; a few clusters that carry a coefficient's information give about their number, where G − p
    would promise far more precision of the variance estimate than those few clusters hold."""
    scale = _unit_diagonal_scale(information)
    inverse = scale[:, None] * np.linalg.pinv(information * scale[:, None] * scale[None, :]) * scale[None, :]
    p = information.shape[0]
    first = np.empty((cluster_squares.shape[0], p, p))   # J_gᵀ A_g J_g
    second = np.empty((cluster_squares.shape[0], p, p))  # J_gᵀ A_g² J_g
    for g, squares in enumerate(cluster_squares):
        values, vectors = np.linalg.eigh(squares)
        kept = values > values.max(initial=0.0) * 1e-12
        root = np.sqrt(values[kept])[:, None] * vectors[:, kept].T  # R with RᵀR = J_gᵀJ_g
        leverage, basis = np.linalg.eigh(root @ inverse @ root.T)  # eigenvalues of H_gg's non-zero part
        remaining = np.maximum(1.0 - leverage, 1e-9)
        first[g] = root.T @ (basis * remaining**-0.5) @ basis.T @ root
        second[g] = root.T @ (basis * remaining**-1.0) @ basis.T @ root
    out = np.empty(p)
    for k in range(p):
        m = inverse[:, k]
        c = first @ m  # (G, p)
        gram = np.diag(second @ m @ m) - c @ inverse @ c.T
        trace = float(np.trace(gram))
        out[k] = trace**2 / float(np.sum(gram**2)) if trace > 0.0 else 1.0
    return out
