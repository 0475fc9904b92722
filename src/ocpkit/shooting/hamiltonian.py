"""Hamiltonian systems of Pontryagin's principle, with piecewise-smooth control laws.

For ``dx/dt = f(x, u)``, cost ``int l(x, u) dt`` and costate ``p``:

    H(x, p, u) = l(x, u) + <p, f(x, u)>,   dp/dt = -dH/dx (x, p, u*),   u* = argmin_{u in U} H.

The minimising control is piecewise smooth: a *mode* selects one smooth branch
``u_mode(x, p)``, and the mode changes where a *switching function* ``g_k(x, p)``
changes sign. Here each group of controls has a scalar switching quantity ``q``
and ascending thresholds ``c_1 < c_2 < ...``; ``g_k = q - c_k`` and the regime is
the number of thresholds below ``q``. On each mode the flow
``phi_mode(y) = (f(x, u_mode), -dH/dx(x, p, u_mode))``, ``y = (x, p)``, is smooth.

:func:`control_law` derives the law from the problem's Hamiltonian for the standard
cases, assuming (and checking numerically) the form

    H = H0(x, p) + psi(x, p) . u + w(x, p) |u| + b(x, p) |u|^2

(``|u|`` the Euclidean norm for a ball, per component for a box): an L1 cost
(``b = 0``: bang-off-bang, with ``w`` the switching level) or the regularised cost
``lambda |u| + (1 - lambda) |u|^2`` of the energy-to-L1 homotopy (``b > 0``:
saturated linear law). ``psi``, ``w`` and ``b`` are extracted exactly by evaluating
H at ``u = 0, +-e_i, 2 e_i``; a mass equation driven by ``|u|`` fits the form.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..problem import Hamiltonian, OptimalControlProblem

CONTROL_SETS = ("box", "ball")


@dataclass
class SwitchingGroup:
    """Controls ``indices`` given by ``controls[regime]`` where ``regime = #{k : quantity > thresholds[k]}``."""

    quantity: ca.SX
    thresholds: list
    controls: list
    indices: tuple

    def __post_init__(self) -> None:
        if len(self.controls) != len(self.thresholds) + 1:
            raise ValueError("a switching group needs one control branch more than it has thresholds")


@dataclass
class ControlLaw:
    """A piecewise-smooth minimiser of H: switching groups over the control vector (see module docstring)."""

    groups: list
    nu: int
    regularized: bool
    control_set: str
    description: str = ""
    hamiltonian: Hamiltonian | None = field(default=None, repr=False)
    """The problem's Hamiltonian; the law's expressions are in its symbols ``x, p, P``."""

    @property
    def group_sizes(self) -> list[int]:
        return [len(g.thresholds) for g in self.groups]

    @property
    def n_switching(self) -> int:
        return sum(self.group_sizes)

    @property
    def n_modes(self) -> int:
        return int(np.prod([s + 1 for s in self.group_sizes]))

    def regimes(self, mode: int) -> list[int]:
        """Regime of each group for a mode index (mixed radix, first group fastest)."""
        out = []
        for size in self.group_sizes:
            out.append(mode % (size + 1))
            mode //= size + 1
        return out

    def mode_of(self, regimes) -> int:
        mode, stride = 0, 1
        for r, size in zip(regimes, self.group_sizes):
            mode += r * stride
            stride *= size + 1
        return mode

    def control(self, mode: int) -> ca.SX:
        """The control branch (SX in the law's x, p, P) of a mode."""
        u = [None] * self.nu
        for g, r in zip(self.groups, self.regimes(mode)):
            branch = g.controls[r]
            for j, i in enumerate(g.indices):
                u[i] = branch[j] if branch.numel() > 1 else branch
        return ca.vertcat(*u)

    def switching(self) -> ca.SX:
        """All switching functions ``g_k = q - c_k`` (SX in x, p, P)."""
        return ca.vertcat(*[g.quantity - c for g in self.groups for c in g.thresholds])


def _extract(H, u, nu: int):
    """psi, w, b (per component for a box, scalar w and b for a ball) from evaluations of H."""
    zero = ca.DM.zeros(nu)
    H0 = ca.substitute(H, u, zero)
    psi, w, b = [], [], []
    for i in range(nu):
        e = ca.DM.zeros(nu)
        e[i] = 1.0
        hp = ca.substitute(H, u, e) - H0
        hm = ca.substitute(H, u, -e) - H0
        h2 = ca.substitute(H, u, 2 * e) - H0
        psi_i = (hp - hm) / 2
        s = (hp + hm) / 2  # w + b
        b_i = (h2 - 2 * psi_i) / 2 - s
        psi.append(psi_i)
        b.append(b_i)
        w.append(s - b_i)
    return H0, psi, w, b


def control_law(
    problem: OptimalControlProblem, control_set: str = "box", *, regularized: bool = False, radius: float = 1.0
) -> ControlLaw:
    """The minimiser of the problem's Hamiltonian for an L1 or regularised cost.

    Parameters
    ----------
    problem : OptimalControlProblem
        Autonomous; its Lagrange cost and dynamics give H (parameters stay symbolic).
    control_set : ``"box"`` (each control within its bounds, which must contain 0) or
        ``"ball"`` (``|u| <= radius``).
    regularized : bool
        False: bang-off-bang (the quadratic coefficient ``b`` must vanish). True:
        saturated linear law for ``b >= 0``, valid for every homotopy parameter
        including the L1 end, where its linear regimes have zero width.
    """
    if control_set not in CONTROL_SETS:
        raise ValueError(f"control_set must be one of {CONTROL_SETS}, got {control_set!r}")
    if problem.L is None:
        raise ValueError("the control law needs a Lagrange cost (an L1 or regularised control cost)")
    nu = problem.nu
    if nu == 0:
        raise ValueError("the problem has no controls")
    ham = problem.functions.hamiltonian
    u, H = ham.u, ham.H
    if ca.depends_on(ca.vertcat(ham.f, ham.L), ham.t):
        raise ValueError("indirect shooting here needs an autonomous problem (no explicit time dependence)")
    _, psi, w, b = _extract(H, u, nu)
    groups = []
    if control_set == "box":
        for i, c in enumerate(problem.controls):
            lo, hi = c.lower, c.upper
            if not (lo <= 0.0 <= hi) or not (np.isfinite(lo) and np.isfinite(hi)):
                raise ValueError(f"box control {c.name!r} needs finite bounds around 0, got [{lo}, {hi}]")
            q = psi[i]
            if regularized:
                thresholds = [-w[i] - 2 * b[i] * hi, -w[i], w[i], w[i] - 2 * b[i] * lo]
                branches = [ca.SX(hi), -(q + w[i]) / (2 * b[i]), ca.SX(0), -(q - w[i]) / (2 * b[i]), ca.SX(lo)]
            else:
                thresholds = [-w[i], w[i]]
                branches = [ca.SX(hi), ca.SX(0), ca.SX(lo)]
            groups.append(SwitchingGroup(q, thresholds, branches, (i,)))
        description = f"box, per-component {'saturated linear' if regularized else 'bang-off-bang'}"
    else:
        if not (radius > 0 and np.isfinite(radius)):
            raise ValueError(f"radius must be positive and finite, got {radius}")
        psi_v = ca.vertcat(*psi)
        norm = ca.norm_2(psi_v)
        direction = -psi_v / norm
        q = norm - w[0]
        if regularized:
            thresholds = [ca.SX(0), 2 * b[0] * radius]
            branches = [ca.DM.zeros(nu), direction * q / (2 * b[0]), radius * direction]
        else:
            thresholds = [ca.SX(0)]
            branches = [ca.DM.zeros(nu), radius * direction]
        groups.append(SwitchingGroup(q, thresholds, [ca.SX(br) for br in branches], tuple(range(nu))))
        description = f"ball |u| <= {radius}, {'saturated linear' if regularized else 'bang-off-bang'}"
    law = ControlLaw(groups, nu, regularized, control_set, description, ham)
    _check_form(problem, law, H, u, psi, w, b)
    return law


def _check_form(problem, law, H, u, psi, w, b, samples: int = 20, tol: float = 1e-8) -> None:
    """H must equal H0 + psi.u + w|u| + b|u|^2 (b = 0 unless regularised); raise ValueError otherwise."""
    x, p, P = law.hamiltonian.x, law.hamiltonian.p, law.hamiltonian.P
    nu = law.nu
    if law.control_set == "box":
        model = sum(psi[i] * u[i] + w[i] * ca.fabs(u[i]) + b[i] * u[i] ** 2 for i in range(nu))
    else:
        model = ca.dot(ca.vertcat(*psi), u) + w[0] * ca.norm_2(u) + b[0] * ca.sumsqr(u)
    H0 = ca.substitute(H, u, ca.DM.zeros(nu))
    residual = ca.Function("residual", [x, p, u, P], [H - H0 - model])
    hfun = ca.Function("h", [x, p, u, P], [H])
    bfun = ca.Function("b", [x, p, P], [ca.vertcat(*b)])
    rng = np.random.default_rng(0)
    pv = problem.parameter_values
    for _ in range(samples):
        xs = np.array([_sample(s) for s in problem.states])
        ps = rng.normal(size=problem.nx)
        us = rng.uniform(-1, 1, size=nu)
        r = abs(float(residual(xs, ps, us, pv)))
        if r > tol * (1 + abs(float(hfun(xs, ps, us, pv)))):
            raise ValueError(
                "the Hamiltonian is not of the form H0 + psi.u + w|u| + b|u|^2 for this control set "
                f"({law.control_set}); this control law does not apply"
            )
        if not law.regularized and np.abs(np.asarray(bfun(xs, ps, pv))).max() > tol:
            raise ValueError("the cost has a quadratic control term: use regularized=True")


def _sample(state) -> float:
    lo, hi = state.lower, state.upper
    if np.isfinite(lo) and np.isfinite(hi):
        return 0.5 * (lo + hi) + 0.25 * (hi - lo)
    if np.isfinite(lo):
        return lo + 1.0 + abs(lo)
    if np.isfinite(hi):
        return hi - 1.0 - abs(hi)
    return 0.7


class HamiltonianSystem:
    """The mode-wise Hamiltonian flows of a problem and a control law, as CasADi functions.

    ``y = (x, p, J)`` of dimension ``n = 2 nx + 1``, where ``dJ/dt = l(x, u)`` accumulates
    the running cost; ``P`` the problem's parameter vector.

    * ``flow(y, mode, P) -> dy/dt`` and, for ``mode`` given as the regimes' mixed
      radix index, the same for every mode through a switch;
    * ``switching(y, P) -> g`` and ``dswitch(y, P) -> dg/dy``;
    * ``hamiltonian(y, mode, P) -> H``, ``control(y, mode, P) -> u``;
    * ``varflow(y, Psi, mode, P) -> (dy/dt, dPsi/dt)`` with ``dPsi/dt = (d phi_mode / dy) Psi``.
    """

    def __init__(self, problem: OptimalControlProblem, law: ControlLaw, n_variational: int | None = None):
        self.problem, self.law = problem, law
        nx = problem.nx
        self.nx, self.n = nx, 2 * nx + 1
        self.n_variational = nx if n_variational is None else int(n_variational)
        law_ham = law.hamiltonian  # the flows are those of the Hamiltonian the law minimises
        if (law_ham.x.numel(), law_ham.P.numel()) != (nx, len(problem.parameters)):
            raise ValueError("the control law was derived for a problem of other dimensions")
        ham = Hamiltonian.of(problem.functions, law_ham.x, law_ham.p, law_ham.P)
        x, p, u, P, f, L, H = ham.x, ham.p, ham.u, ham.P, ham.f, ham.L, ham.H
        J = ca.SX.sym("J")
        dHdx = ca.gradient(H, x)
        y = ca.vertcat(x, p, J)
        mode = ca.SX.sym("mode")
        Psi = ca.SX.sym("Psi", self.n, self.n_variational)
        flows, hams, ctrls, varflows = [], [], [], []
        for m in range(law.n_modes):
            um = law.control(m)
            phi = ca.vertcat(ca.substitute(f, u, um), -ca.substitute(dHdx, u, um), ca.substitute(L, u, um))
            flows.append(phi)
            hams.append(ca.substitute(H, u, um))
            ctrls.append(um)
            varflows.append(ca.jtimes(phi, y, Psi))
        sel = ca.conditional
        zero_phi = ca.SX.zeros(self.n)
        self.flow = ca.Function("ocp_flow", [y, mode, P], [sel(mode, flows, zero_phi)], ["y", "mode", "P"], ["ydot"])
        self.hamiltonian = ca.Function("ocp_ham", [y, mode, P], [sel(mode, hams, ca.SX(0))], ["y", "mode", "P"], ["H"])
        self.control = ca.Function(
            "ocp_control", [y, mode, P], [sel(mode, ctrls, ca.SX.zeros(law.nu))], ["y", "mode", "P"], ["u"]
        )
        g = law.switching()
        self.switching = ca.Function("ocp_switching", [y, P], [g], ["y", "P"], ["g"])
        self.dswitch = ca.Function("ocp_dswitch", [y, P], [ca.densify(ca.jacobian(g, y))], ["y", "P"], ["dg"])
        self.varflow = ca.Function(
            "ocp_varflow",
            [y, Psi, mode, P],
            [sel(mode, flows, zero_phi), sel(mode, varflows, ca.SX.zeros(self.n, self.n_variational))],
            ["y", "Psi", "mode", "P"],
            ["ydot", "Psidot"],
        )
        self._branches = (y, Psi, P, flows, varflows, hams)

    def compiled_functions(self) -> list[ca.Function]:
        """The functions the C integrator calls: flow, varflow, switching, dswitch, hamiltonian.

        Same names and signatures as :attr:`flow`, :attr:`varflow`, ... but the
        mode selects its branch through a C ``switch`` (``Function.conditional``),
        so each call evaluates one mode; an SX ``conditional`` evaluates every branch.
        """
        y, Psi, P, flows, varflows, hams = self._branches
        mode = ca.MX.sym("mode")

        def switched(name, sx_inputs, branches, names_in, names_out):
            per_mode = [ca.Function(f"{name}_{m}", sx_inputs, list(b)) for m, b in enumerate(branches)]
            zero = ca.Function(f"{name}_none", sx_inputs, [ca.SX.zeros(o.sparsity()) for o in branches[0]])
            select = ca.Function.conditional(f"{name}_switch", per_mode, zero)
            mx = [ca.MX.sym(n, s.sparsity()) for n, s in zip([n for n in names_in if n != "mode"], sx_inputs)]
            out = select(mode, *mx)
            out = out if isinstance(out, (list, tuple)) else [out]
            inputs = mx[:-1] + [mode, mx[-1]]  # (..., mode, P), as the SX functions
            return ca.Function(name, inputs, list(out), names_in, names_out)

        flow = switched("ocp_flow", [y, P], [(phi,) for phi in flows], ["y", "mode", "P"], ["ydot"])
        varflow = switched(
            "ocp_varflow", [y, Psi, P], list(zip(flows, varflows)), ["y", "Psi", "mode", "P"], ["ydot", "Psidot"]
        )
        ham = switched("ocp_ham", [y, P], [(h,) for h in hams], ["y", "mode", "P"], ["H"])
        return [flow, varflow, self.switching, self.dswitch, ham]

    def mode_at(self, y, P) -> int:
        """The mode selected by the signs of the switching functions at ``y``."""
        g = np.asarray(self.switching(y, P)).ravel()
        regimes, k = [], 0
        for size in self.law.group_sizes:
            regimes.append(int(np.sum(g[k : k + size] > 0)))
            k += size
        return self.law.mode_of(regimes)
