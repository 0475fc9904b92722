"""Separable NLPs: small CasADi functions mapped over many instances.

A collocation NLP is a sum of identical pieces: one defect function per
segment, one quadrature term per segment, one Mayer term. Each piece (a
:class:`Block`) is a small SX function ``out = F(z, p)`` of a few decision
variables ``z`` (gathered from the NLP vector ``w`` by an index table) and
numeric constants ``p``. Constraint blocks add their outputs into rows of ``g``;
objective blocks add into ``f``.

CasADi can differentiate the mapped graph itself, but its Hessian sparsity
detection and colouring scale quadratically when one variable (a free final
time) couples every segment. Here the derivatives are assembled instead: each
block's Jacobian and Lagrangian Hessian are computed symbolically once, on one
instance, mapped over the instances, and scattered into the global sparse
matrices by a constant assembly matrix. Build time is linear in the number of
instances, and IPOPT receives the exact Hessian (options ``jac_g`` and
``hess_lag`` of CasADi's IPOPT interface).
"""

from __future__ import annotations

import difflib
import re
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from ._arrays import unique
from ._compiled_blocks import (  # noqa: F401 (THREAD_THRESHOLD: its home before)
    THREAD_THRESHOLD,
    CompilationWarning,
    compiled_maps,
    interpreted_map,
)
from ._deprecation import renamed

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

DEFAULT_IPOPT_OPTIONS = {
    "print_level": 0,
    "sb": "yes",
    "tol": 1e-10,
    "max_iter": 3000,
    "mu_strategy": "adaptive",
    # MUMPS: QAMD ordering, no MC64 permuting-scaling. Measured on the HLGL lunar
    # ascent, 5000 segments (benchmarks/bench_hlgl.py): solve 8.8 s -> 2.1 s, and
    # factorisation time grows about linearly with the mesh instead of ~n^2.
    "mumps_pivot_order": 6,
    "mumps_permuting_scaling": 0,
}
"""IPOPT options used unless overridden (exact Hessian, MUMPS)."""

#: MUMPS's orderings by ``mumps_pivot_order`` (IPOPT's option)
MUMPS_ORDERINGS = {0: "AMD", 1: "user", 2: "AMF", 3: "SCOTCH", 4: "PORD", 5: "METIS", 6: "QAMD", 7: "automatic"}


def linear_solver(options: dict | None = None) -> str:
    """IPOPT's linear solver and, for MUMPS, its fill-reducing ordering under ``options`` (IPOPT options, over
    :data:`DEFAULT_IPOPT_OPTIONS`): e.g. ``"mumps (QAMD ordering)"``."""
    ip = {**DEFAULT_IPOPT_OPTIONS, **(options or {})}
    name = str(ip.get("linear_solver", "mumps"))
    if name != "mumps":
        return name
    order = ip.get("mumps_pivot_order", 7)
    return f"mumps ({MUMPS_ORDERINGS.get(int(order), str(order))} ordering)"


WARM_START = {
    "warm_start_init_point": "yes",
    "mu_init": 1e-6,
    "warm_start_bound_push": 1e-9,
    "warm_start_bound_frac": 1e-9,
    "warm_start_slack_bound_push": 1e-9,
    "warm_start_slack_bound_frac": 1e-9,
    "warm_start_mult_bound_push": 1e-9,
}
"""IPOPT options of a start from a previous solution of the same NLP with its multipliers.

The iterate is kept (almost) where it is instead of being pushed into the interior, and the barrier starts small.
From its own solution, the entry landing (Radau 4 x 20) takes 1 iteration instead of 15."""


@dataclass
class Block:
    """``count`` instances of ``function(z, p) -> out`` inside an NLP.

    Attributes
    ----------
    name : str
    function : casadi.Function
        SX function with inputs ``z`` (nz) and ``p`` (np) and one column output (nout).
    variables : numpy.ndarray
        Integers, shape ``(nz, count)``: the global NLP variable index of each entry of ``z``, per instance.
    constants : numpy.ndarray
        Floats, shape ``(np, count)``: the block's constant inputs ``p`` per instance (mesh data, a fixed final
        time); ``parameters`` is their deprecated name.
    rows : numpy.ndarray or None
        Integers, shape ``(nout, count)``: the constraint rows that receive each output (summed where shared);
        ``None`` makes the block an objective term (``nout == 1``, summed into ``f``).
    linear : numpy.ndarray or None
        Floats, shape ``(nout, nz)``. For a block that is the linear map ``out = linear @ z`` (the same for every
        instance): its Jacobian is this constant and its Hessian zero, so neither is
        differentiated symbolically (a dense map of a few hundred variables would
        take seconds).
    """

    name: str
    function: ca.Function
    variables: np.ndarray
    constants: np.ndarray
    rows: np.ndarray | None = None
    linear: np.ndarray | None = None

    @property
    def parameters(self) -> np.ndarray:
        """Deprecated name of :attr:`constants`."""
        renamed("Block.parameters", "Block.constants")
        return self.constants

    def __post_init__(self) -> None:
        self.variables = np.asarray(self.variables, dtype=np.int64)
        self.constants = np.asarray(self.constants, dtype=float)
        nz, count = self.variables.shape
        npar = self.function.size1_in(1)
        if self.constants.shape != (npar, count):
            raise ValueError(
                f"block {self.name!r}: constants have shape {self.constants.shape}, expected ({npar}, {count})"
            )
        if self.function.size1_in(0) != nz:
            raise ValueError(
                f"block {self.name!r}: function takes {self.function.size1_in(0)} variables, index table has {nz}"
            )
        nout = self.function.size1_out(0)
        if self.rows is None:
            if nout != 1:
                raise ValueError(f"objective block {self.name!r} must have a scalar output")
        else:
            self.rows = np.asarray(self.rows, dtype=np.int64)
            if self.rows.shape != (nout, count):
                raise ValueError(f"block {self.name!r}: rows have shape {self.rows.shape}, expected ({nout}, {count})")
        if self.linear is not None:
            self.linear = np.asarray(self.linear, dtype=float)
            if self.rows is None or self.linear.shape != (nout, nz):
                raise ValueError(f"block {self.name!r}: a linear map must be a ({nout}, {nz}) constraint block")


def _nonzeros(expr: ca.SX) -> ca.SX:
    # (vertcat takes the SX entries nonzeros() returns; its stub lists matrices only)
    return ca.vertcat(*expr.nonzeros()) if expr.nnz() else ca.SX(0, 1)  # type: ignore[call-overload]


_map = interpreted_map  # (its name before)


def _assemble(keys: np.ndarray, weights: np.ndarray, values: ca.MX) -> tuple[np.ndarray, ca.MX]:
    """Unique sorted keys and the entries of ``values`` (one per key occurrence, times its weight) summed into them.

    A key that occurs once with weight 1 (every row of the defects, every Jacobian entry, most Hessian entries)
    takes its entry as it is: the sum is a gather (nothing at all where the entries are already in order). Only the
    keys that sum several entries or weigh one (a free final time's Hessian entries, which every segment touches)
    go through a sparse product, over their entries alone, in the entries' order as before, so the result is the
    full product's to the last bit (a gathered zero keeps its sign, where ``0 + 1 * (-0.0)`` was ``+0.0``).
    Building the full product took a third of the lunar ascent's HLGL 5000 build (0.56 s before, 0.27 s after).
    """
    keys = np.asarray(keys, dtype=np.int64).ravel()
    weights = np.asarray(weights, dtype=float).ravel()
    n = keys.size
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    starts = np.flatnonzero(np.concatenate([[True], ordered[1:] != ordered[:-1]])) if n else np.zeros(0, np.int64)
    ukeys = ordered[starts]
    counts = np.diff(np.concatenate([starts, [n]]))
    single = (counts == 1) & (weights[order[starts]] == 1.0)
    if single.all():
        if np.array_equal(order, np.arange(n)):
            return ukeys, values
        return ukeys, values[order.tolist()]
    # the summed keys: a product over their entries (columns in the entries' order, as the full product's)
    key_of_entry = np.repeat(np.arange(ukeys.size), counts)
    summed_entry = ~single[key_of_entry]
    positions = order[summed_entry]
    rank = np.cumsum(~single) - 1
    rows = rank[key_of_entry[summed_entry]]
    by_position = np.argsort(positions, kind="stable")
    positions, rows = positions[by_position], rows[by_position]
    m = positions.size
    sparsity = ca.Sparsity(int((~single).sum()), m, np.arange(m + 1).tolist(), rows.tolist())
    summed = ca.mtimes(ca.DM(sparsity, weights[positions]), values[positions.tolist()])
    index = np.empty(ukeys.size, np.int64)
    index[single] = order[starts[single]]
    index[~single] = n + np.arange(sparsity.size1())
    return ukeys, ca.vertcat(values, summed)[index.tolist()]


def _column_major(shape: tuple[int, int], keys: np.ndarray) -> ca.Sparsity:
    """The sparsity of sorted column-major ``keys`` (``column * rows + row``), built from its CCS arrays."""
    rows, columns = shape
    keys = np.asarray(keys, dtype=np.int64)
    if not keys.size:
        return ca.Sparsity(rows, columns)
    colind = np.searchsorted(keys // rows, np.arange(columns + 1))
    return ca.Sparsity(rows, columns, colind.tolist(), (keys % rows).tolist())


class SeparableNLP:
    """An NLP ``min f(w) s.t. lbg <= g(w) <= ubg, lbw <= w <= ubw`` built from blocks."""

    def __init__(self, n_variables: int, n_constraints: int, blocks: list[Block], compile: str | bool = "auto") -> None:
        self.n_variables = int(n_variables)
        self.compile = compile
        self.n_constraints = int(n_constraints)
        self.blocks = list(blocks)
        for b in self.blocks:
            if b.variables.size and (b.variables.min() < 0 or b.variables.max() >= self.n_variables):
                raise ValueError(f"block {b.name!r} indexes variables outside [0, {self.n_variables})")
            if b.rows is not None and b.rows.size and (b.rows.min() < 0 or b.rows.max() >= self.n_constraints):
                raise ValueError(f"block {b.name!r} writes rows outside [0, {self.n_constraints})")
        self._build()

    # ------------------------------------------------------------------------------
    def _build(self) -> None:
        N, M = self.n_variables, self.n_constraints
        w = ca.MX.sym("w", N)
        p = ca.MX.sym("p", 0)
        lam_f = ca.MX.sym("lam_f")
        lam_g = ca.MX.sym("lam_g", M)

        f_terms: list[ca.MX] = []
        g_vals: list[ca.MX] = []
        g_rows: list[np.ndarray] = []
        g_jac_vals: list[ca.MX] = []
        hessian_instructions = 0
        j_vals: list[ca.MX | ca.DM] = []
        j_rows: list[np.ndarray] = []
        j_cols: list[np.ndarray] = []
        h_vals: list[ca.MX] = []
        h_rows: list[np.ndarray] = []
        h_cols: list[np.ndarray] = []
        h_wts: list[np.ndarray] = []

        # the blocks' derivative functions, symbolically on one instance each: (jac, hess, jac alone, rows and
        # columns of the Jacobian's nonzeros, of the Hessian's)
        derivatives: list[tuple[Any, ...]] = []
        for k, b in enumerate(self.blocks):
            nz, count = b.variables.shape
            z = ca.SX.sym("z", nz)
            q = ca.SX.sym("q", b.constants.shape[0])
            out = b.function(z, q)
            lam = ca.SX.sym("lam", b.function.size1_out(0))
            jfun = jalone = hfun = None
            hr = hc = jr = jc = np.zeros(0, np.int64)
            if b.linear is None:
                H = ca.triu(ca.hessian(ca.dot(lam, out), z)[0])
                hr, hc = (np.asarray(v, dtype=np.int64) for v in H.sparsity().get_triplet())
                if hr.size:
                    hfun = ca.Function(f"b{k}_{b.name}_hess", [z, q, lam], [_nonzeros(H)])
                    hessian_instructions += hfun.n_instructions() * count
            if b.rows is not None:
                if b.linear is None:
                    J = ca.jacobian(out, z)
                    jr, jc = (np.asarray(v, dtype=np.int64) for v in J.sparsity().get_triplet())
                    if jr.size:
                        # compiled: with the values (jac_g's own, sharing subexpressions); interpreted: alone
                        jfun = ca.Function(f"b{k}_{b.name}_jac", [z, q], [out, _nonzeros(J)])
                        jalone = ca.Function(f"b{k}_{b.name}_jac", [z, q], [_nonzeros(J)])
                else:
                    jc, jr = (a.astype(np.int64) for a in np.nonzero(b.linear.T))  # column-major order
            derivatives.append((jfun, hfun, jalone, jr, jc, hr, hc))
        mapped = compiled_maps(self.blocks, derivatives, self.compile)
        self.compiled = mapped.library

        for b, (jfun, hfun, jalone, jr, jc, hr, hc) in zip(self.blocks, derivatives):
            nz, count = b.variables.shape
            nout = b.function.size1_out(0)
            Z = ca.reshape(w[b.variables.ravel(order="F").tolist()], nz, count)
            P = ca.DM(b.constants)
            vals = _map(b.function, count)(Z, P)
            if b.rows is None:
                f_terms.append(ca.sum2(vals))
                lam_in = ca.repmat(lam_f, 1, count)
            else:
                g_vals.append(ca.vec(vals))
                g_jac_vals.append(g_vals[-1])
                g_rows.append(b.rows.ravel(order="F"))
                if jr.size:
                    if b.linear is not None:
                        j_vals.append(ca.DM(np.tile(b.linear[jr, jc], count)))
                    elif mapped.compiled(jfun):
                        # compiled with the values, whose subexpressions it shares: jac_g's own constraint values
                        values_again, jac_values = mapped(jfun, count)(Z, P)
                        g_jac_vals[-1] = ca.vec(values_again)
                        j_vals.append(ca.vec(jac_values))
                    else:
                        j_vals.append(ca.vec(_map(jalone, count)(Z, P)))
                    j_rows.append(b.rows[jr, :].ravel(order="F"))
                    j_cols.append(b.variables[jc, :].ravel(order="F"))
                lam_in = ca.reshape(lam_g[b.rows.ravel(order="F").tolist()], nout, count)
            if hfun is not None:
                h_vals.append(ca.vec(mapped(hfun, count)(Z, P, lam_in)))
                gr = b.variables[hr, :]
                gc = b.variables[hc, :]
                # an off-diagonal local entry landing on a global diagonal counts twice
                wt = np.where((hr != hc)[:, None] & (gr == gc), 2.0, 1.0)
                h_rows.append(np.minimum(gr, gc).ravel(order="F"))
                h_cols.append(np.maximum(gr, gc).ravel(order="F"))
                h_wts.append(wt.ravel(order="F"))

        f = sum(f_terms[1:], f_terms[0]) if f_terms else ca.MX(0)
        if g_vals:
            rows = np.concatenate(g_rows)
            _, g = _assemble(rows, np.ones(rows.size), ca.vertcat(*g_vals))
            if not np.array_equal(unique(rows), np.arange(M)):
                raise ValueError("every constraint row must receive at least one block output")
            g_jac = g
            if any(a is not b for a, b in zip(g_jac_vals, g_vals)):  # (the same nodes: evaluated once)
                _, g_jac = _assemble(rows, np.ones(rows.size), ca.vertcat(*g_jac_vals))
        else:
            g = g_jac = ca.MX(0, 1)

        jr = np.concatenate(j_rows) if j_rows else np.zeros(0, np.int64)
        jc = np.concatenate(j_cols) if j_cols else np.zeros(0, np.int64)
        keys = jc * M + jr
        ukeys, jac_nz = _assemble(keys, np.ones(keys.size), ca.vertcat(*j_vals) if j_vals else ca.MX(0, 1))
        sp_j = _column_major((M, N), ukeys)
        jac = ca.MX(sp_j, jac_nz) if j_vals else ca.MX(M, N)

        hr = np.concatenate(h_rows) if h_rows else np.zeros(0, np.int64)
        hc = np.concatenate(h_cols) if h_cols else np.zeros(0, np.int64)
        keys = hc * N + hr
        weights = np.concatenate(h_wts) if h_wts else np.zeros(0)
        ukeys, hess_nz = _assemble(keys, weights, ca.vertcat(*h_vals) if h_vals else ca.MX(0, 1))
        sp_h = _column_major((N, N), ukeys)
        hess = ca.MX(sp_h, hess_nz) if h_vals else ca.MX(N, N)

        self.w, self.f, self.g = w, f, g
        self.jac_g = ca.Function("nlp_jac_g", [w, p], [g_jac, jac], ["x", "p"], ["g", "jac_g_x"])
        self.hess_lag = ca.Function(
            "nlp_hess_l", [w, p, lam_f, lam_g], [hess], ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]
        )
        self.nnz_jacobian = sp_j.nnz()
        self.nnz_hessian = sp_h.nnz()
        #: CasADi instructions of one evaluation of the blocks' Hessians (the work of ``hess_lag`` before assembly)
        self.hessian_instructions = int(hessian_instructions)

    # ------------------------------------------------------------------------------
    def multiplier_estimate(self, w: ArrayLike, lbw: ArrayLike, ubw: ArrayLike) -> tuple[np.ndarray, np.ndarray] | None:
        """First-order multiplier estimates ``(lam_g, lam_w)`` at a point ``w`` (scaled, within its bounds), or
        None where they cost more than a solve would save.

        ``lam_g`` minimises the Lagrangian's gradient over the variables not at a bound, ``J_F^T lam_g =
        -grad_F f`` in the least-squares sense (:func:`least_squares_multipliers`: sparse normal equations, with
        the few dense columns of a free time or a free parameter bordered instead of multiplied out); ``lam_w``
        takes what remains of the gradient at the variables on a bound. With :data:`WARM_START`, an interpolated
        point and these estimates start IPOPT near the central path's end (mesh refinement: the entry landing's
        later meshes take 6 to 10 IPOPT iterations instead of 26 to 31).
        """
        import scipy.sparse as sps

        w = np.asarray(w, dtype=float)
        lbw, ubw = np.asarray(lbw, dtype=float), np.asarray(ubw, dtype=float)
        _, jac = self.jac_g(w, [])
        jac = ca.DM(jac)
        rows, cols = jac.sparsity().get_triplet()
        J = sps.csc_matrix((np.asarray(jac.nonzeros()), (rows, cols)), shape=jac.shape)
        grad = np.asarray(self._objective_gradient(w)).ravel()
        with np.errstate(invalid="ignore"):
            near_lower = np.isfinite(lbw) & ((w - lbw) <= 1e-9 * np.maximum(1.0, np.abs(lbw)))
            near_upper = np.isfinite(ubw) & ((ubw - w) <= 1e-9 * np.maximum(1.0, np.abs(ubw)))
        on_bound = near_lower | near_upper
        try:  # a warm-start aid: whatever goes wrong here, the solve starts without it
            lam_g = least_squares_multipliers(J[:, ~on_bound], grad[~on_bound])
        except (RuntimeError, MemoryError, ValueError, ArithmeticError):
            return None
        if lam_g is None or not np.all(np.isfinite(lam_g)):
            return None
        residual = grad + J.T @ lam_g
        lam_w = np.where(on_bound, -residual, 0.0)
        return lam_g, lam_w

    @cached_property
    def constraint_function(self) -> ca.Function:
        """``g(w)``, the constraint values (built when first asked for; a solve does not need it)."""
        return ca.Function("g", [self.w], [self.g])

    @cached_property
    def objective_function(self) -> ca.Function:
        """``f(w)``, the objective (built when first asked for)."""
        return ca.Function("f", [self.w], [self.f])

    @property
    def _objective_gradient(self) -> ca.Function:
        if not hasattr(self, "_grad_f"):
            self._grad_f = ca.Function("grad_f", [self.w], [ca.gradient(self.f, self.w)])
        return self._grad_f

    def solver(self, ipopt_options: dict | None = None) -> ca.Function:
        """CasADi ``nlpsol`` (IPOPT) for this NLP: the assembled exact Hessian, or, with the option
        ``hessian_approximation="limited-memory"``, IPOPT's L-BFGS approximation instead (a quasi-Newton
        method, for comparisons with solvers of that class)."""
        ip = dict(DEFAULT_IPOPT_OPTIONS)
        ip.update(ipopt_options or {})
        approximation = ip.get("hessian_approximation", "exact")
        if approximation not in ("exact", "limited-memory"):
            raise ValueError(f"hessian_approximation must be 'exact' or 'limited-memory', got {approximation!r}")
        opts: dict[str, Any] = {"ipopt": ip, "print_time": False, "jac_g": self.jac_g}
        if approximation == "exact":
            opts["hess_lag"] = self.hess_lag
        try:
            return ca.nlpsol("ocpkit_nlp", "ipopt", {"x": self.w, "f": self.f, "g": self.g}, opts)
        except RuntimeError as exc:
            unknown = re.search(r"No such IPOPT option: (\S+)", str(exc))
            if unknown is None:
                raise
            raise ValueError(unknown_ipopt_option(unknown.group(1), ip)) from None


#: IPOPT options a user of ocpkit sets, to suggest the one meant by a misspelt name (IPOPT has many more)
KNOWN_IPOPT_OPTIONS = (
    "tol", "max_iter", "max_cpu_time", "max_wall_time", "acceptable_tol", "acceptable_iter", "constr_viol_tol",
    "dual_inf_tol", "compl_inf_tol", "print_level", "print_timing_statistics", "sb", "linear_solver",
    "mu_strategy", "mu_init", "mu_oracle", "nlp_scaling_method", "obj_scaling_factor", "hessian_approximation",
    "warm_start_init_point", "warm_start_bound_push", "warm_start_mult_bound_push", "bound_push", "bound_frac",
    "bound_relax_factor", "mumps_pivtol", "mumps_mem_percent", "mumps_permuting_scaling", "mumps_scaling",
    "ma57_pivot_order", "expect_infeasible_problem", "check_derivatives_for_naninf", "derivative_test",
)  # fmt: skip


def unknown_ipopt_option(name: str, given: Mapping[str, Any]) -> str:
    """The message of an IPOPT option name IPOPT does not know: the name, the one meant if close to a known one
    (:data:`KNOWN_IPOPT_OPTIONS` and the options given), and where the options are listed."""
    close = difflib.get_close_matches(name, [k for k in (*KNOWN_IPOPT_OPTIONS, *given) if k != name], n=1)
    meant = f"; did you mean {close[0]!r}?" if close else ""
    return (
        f"ipopt_options: IPOPT has no option {name!r}{meant} (the names are IPOPT's, without CasADi's 'ipopt.' "
        "prefix: https://coin-or.github.io/Ipopt/OPTIONS.html)"
    )


#: Work budget of :func:`least_squares_multipliers`, in nonzeros of the normal matrix (8 bytes each, before fill).
NORMAL_MATRIX_BUDGET = 4_000_000


def dense_columns(A: Any, factor: float = 10.0, minimum: int = 64) -> np.ndarray:
    """Columns of a sparse ``A`` (m x n, CSC) with more than ``max(minimum, factor sqrt(m))`` nonzeros: the
    variables that couple a whole mesh (a free initial or final time, a free parameter). ``A A'`` would be
    dense through any of them (issue: a free t_f made the hang glider's 10,744 x 10,744 normal matrix full)."""
    counts = np.diff(A.indptr)
    return counts > max(minimum, factor * np.sqrt(A.shape[0]))


def least_squares_multipliers(
    A: Any,
    g: ArrayLike,
    regularisation: float = 1e-12,
    budget: int | None = None,
    stats: dict[str, Any] | None = None,
) -> np.ndarray | None:
    """``lam`` minimising ``|A' lam + g|`` (``A``: m x n sparse, m <= n), or None if its normal matrix would
    hold more than ``budget`` nonzeros (default :data:`NORMAL_MATRIX_BUDGET`).

    The normal equations ``(A A' + delta I) lam = -A g`` are solved directly when ``A`` has no dense column.
    With ``k`` dense columns ``A_d`` (:func:`dense_columns`) and the rest ``A_s``, the same equations are solved
    through the bordered, quasi-definite system

        [ A_s A_s' + delta I   A_d ] [ lam ]   [ -A g ]
        [ A_d'                 -I  ] [  y  ] = [   0  ],

    whose first block row is ``(A_s A_s' + A_d A_d' + delta I) lam = -A g`` once ``y = A_d' lam`` is eliminated:
    sparse whatever ``k``, factorised by SuperLU in a symmetric minimum-degree ordering (which leaves the k dense
    rows, of high degree, to the end). What is formed before any factorisation is bounded by ``budget`` (the
    normal matrix's nonzeros); the factors' fill is checked after, and an estimate whose factors exceed four
    budgets is not used. ``stats``, a dict, receives the dense columns' count, the normal matrix's nonzeros and the
    factors' (``dense_columns``, ``normal_nnz``, ``factor_nnz``).
    """
    import scipy.sparse as sps
    from scipy.sparse.linalg import splu, spsolve

    budget = NORMAL_MATRIX_BUDGET if budget is None else budget
    A = sps.csc_matrix(A)
    m = A.shape[0]
    if m == 0:
        return np.zeros(0)
    dense = dense_columns(A)
    counts = np.diff(A.indptr)[~dense].astype(np.int64)
    if int(np.sum(counts**2)) > budget:  # an upper bound of nnz(A_s A_s') and of the work of forming it
        return None
    rhs = -(A @ g)
    A_s = A[:, ~dense]
    normal = (A_s @ A_s.T + regularisation * sps.identity(m, format="csc")).tocsc()
    if stats is not None:
        stats.update(dense_columns=int(dense.sum()), normal_nnz=int(normal.nnz), factor_nnz=None)
    if normal.nnz > budget:
        return None
    if not dense.any():
        return np.atleast_1d(spsolve(normal, rhs))
    A_d = A[:, dense]
    k = A_d.shape[1]
    bordered = sps.bmat([[normal, A_d], [A_d.T, -sps.identity(k)]], format="csc")
    lu = splu(bordered, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    if stats is not None:
        stats["factor_nnz"] = int(lu.L.nnz + lu.U.nnz)
    if lu.L.nnz + lu.U.nnz > 4 * budget:
        return None
    return lu.solve(np.concatenate([rhs, np.zeros(k)]))[:m]


@dataclass
class NLPResult:
    """Raw result of one IPOPT solve (scaled NLP variables): the last iterate, whether or not it succeeded."""

    w: np.ndarray
    objective: float
    lam_g: np.ndarray
    lam_w: np.ndarray
    status: str
    iterations: int
    solve_s: float
    success: bool
    stats: dict[str, Any] = field(repr=False, default_factory=dict)


ACCEPTABLE = "Solved_To_Acceptable_Level"


def succeeded(status: str, w: np.ndarray, allow_acceptable: bool = False) -> bool:
    """An IPOPT solve's success: ``Solve_Succeeded`` (or ``Solved_To_Acceptable_Level`` with ``allow_acceptable``)
    with a finite iterate ``w``."""
    return (status == "Solve_Succeeded" or (allow_acceptable and status == ACCEPTABLE)) and bool(np.isfinite(w).all())


def solve_nlp(
    solver: ca.Function,
    w0: np.ndarray,
    lbw: np.ndarray,
    ubw: np.ndarray,
    lbg: np.ndarray,
    ubg: np.ndarray,
    *,
    allow_acceptable: bool = False,
    lam_w0: np.ndarray | None = None,
    lam_g0: np.ndarray | None = None,
) -> NLPResult:
    """Run IPOPT and return its last iterate; ``success`` says whether IPOPT succeeded.

    Success is ``Solve_Succeeded``, or ``Solved_To_Acceptable_Level`` with
    ``allow_acceptable``, and a finite iterate. ``lam_w0``, ``lam_g0``: starting multipliers
    (with :data:`WARM_START` options).
    """
    for name, arr in (("lower bounds", lbw), ("upper bounds", ubw)):
        if np.any(np.isnan(arr)):
            raise ValueError(f"NaN in NLP variable {name}")
    bad = np.flatnonzero(np.asarray(lbw) > np.asarray(ubw))
    if bad.size:
        raise ValueError(f"impossible variable bounds (lower > upper) at NLP indices {bad[:10].tolist()}")
    if not np.all(np.isfinite(w0)):
        raise ValueError("the initial guess contains NaN or infinite values")
    t = time.perf_counter()
    start: dict[str, Any] = {} if lam_w0 is None else {"lam_x0": lam_w0, "lam_g0": lam_g0}
    res = solver(x0=w0, lbx=lbw, ubx=ubw, lbg=lbg, ubg=ubg, **start)
    elapsed = time.perf_counter() - t
    stats = solver.stats()
    status = stats.get("return_status", "unknown")
    iters = int(stats.get("iter_count", -1))
    w = np.asarray(res["x"]).ravel()
    ok = succeeded(status, w, allow_acceptable)
    return NLPResult(
        w=w,
        objective=float(res["f"]),
        lam_g=np.asarray(res["lam_g"]).ravel(),
        lam_w=np.asarray(res["lam_x"]).ravel(),
        status=status,
        iterations=iters,
        solve_s=elapsed,
        success=ok,
        stats={k: v for k, v in stats.items() if isinstance(v, (bool, int, float, str))},
    )


def solve_nlp_slsqp(
    nlp: SeparableNLP,
    w0: ArrayLike,
    lbw: ArrayLike,
    ubw: ArrayLike,
    lbg: ArrayLike,
    ubg: ArrayLike,
    *,
    maxiter: int = 2000,
    ftol: float = 1e-12,
) -> NLPResult:
    """Solve with SciPy's SLSQP (Kraft's sequential least squares: an SQP method with a dense BFGS
    approximation of the Lagrangian Hessian, exact gradients from CasADi): the class of solver of the
    1990s-2000s trajectory-optimisation literature (NPSOL, SNOPT's dense cousins). Dense: for NLPs of a few
    hundred variables. Returns an :class:`NLPResult` (no multipliers: SLSQP does not return them)."""
    from scipy.optimize import Bounds, minimize

    f, grad, g = nlp.objective_function, nlp._objective_gradient, nlp.constraint_function

    def jac(x: np.ndarray) -> np.ndarray:  # the NLP's own assembled Jacobian, densified for SLSQP
        return np.asarray(ca.DM(nlp.jac_g(x, [])[1]).full())

    lbg, ubg = np.asarray(lbg, dtype=float), np.asarray(ubg, dtype=float)
    eq = lbg == ubg
    constraints = []
    if eq.any():
        constraints.append(
            {
                "type": "eq",
                "fun": lambda x: np.asarray(g(x)).ravel()[eq] - lbg[eq],
                "jac": lambda x: jac(x)[eq],
            }
        )
    for bound, sign in ((lbg, 1.0), (ubg, -1.0)):
        rows = ~eq & np.isfinite(bound)
        if rows.any():
            constraints.append(
                {
                    "type": "ineq",
                    "fun": lambda x, r=rows, b=bound, s=sign: s * (np.asarray(g(x)).ravel()[r] - b[r]),
                    "jac": lambda x, r=rows, s=sign: s * jac(x)[r],
                }
            )
    t = time.perf_counter()
    res = minimize(
        lambda x: float(f(x)),
        np.asarray(w0, dtype=float),
        jac=lambda x: np.asarray(grad(x)).ravel(),
        method="SLSQP",
        bounds=Bounds(lbw, ubw),
        constraints=constraints,
        options={"maxiter": maxiter, "ftol": ftol},
    )
    elapsed = time.perf_counter() - t
    x = np.asarray(res.x, dtype=float)
    return NLPResult(
        w=x,
        objective=float(res.fun),
        lam_g=np.zeros(nlp.n_constraints),
        lam_w=np.zeros(nlp.n_variables),
        status=f"SLSQP: {res.message}",
        iterations=int(res.nit),
        solve_s=elapsed,
        success=bool(res.success) and bool(np.all(np.isfinite(x))),
    )


def failure_hint(status: str) -> str:
    """What to do about a failed IPOPT status (for error messages)."""
    if status == ACCEPTABLE:
        return (
            "IPOPT stopped at its acceptable (looser) tolerances; pass allow_acceptable=True to accept this "
            "solution, or tighten the problem's scaling"
        )
    return "the last iterate is attached to the error as .result; solve(raise_on_failure=False) returns it instead"
