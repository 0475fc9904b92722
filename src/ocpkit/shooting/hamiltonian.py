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
cases, assuming (and checking numerically) the form::

    H = H0(x, p) + psi(x, p) . u + w(x, p) |u| + b(x, p) |u|^2

(``|u|`` the Euclidean norm for a ball, per component for a box): an L1 cost
(``b = 0``: bang-off-bang, with ``w`` the switching level) or the regularised cost
``lambda |u| + (1 - lambda) |u|^2`` of the energy-to-L1 homotopy (``b > 0``:
saturated linear law). ``psi``, ``w`` and ``b`` are extracted exactly by evaluating
H at ``u = 0, +-e_i, 2 e_i`` (:func:`ocpkit.hamiltonian_form.decompose`); a mass
equation driven by ``|u|`` fits the form. An unbounded box control suits the
regularised law when ``b > 0`` (the saturation on an infinite side never occurs),
never the bang-off-bang one (H, affine in ``u``, has no minimum then).

Any other Hamiltonian (``u`` entering through ``cos u``, a brachistochrone; a
non-quadratic cost) needs the minimiser from the user: ``control_law(problem, u_star)``
with ``u_star(x, p)`` (``u_star(x, p, params)`` for a problem with named parameters)
returning CasADi expressions of ``u* = argmin_u H(x, p, u)``. Such a law is smooth:
one mode, no switching function, so the integrator's switching options do nothing.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import casadi as ca
import numpy as np

from ..hamiltonian_form import decompose, sample_value
from ..names import Named, NamedParameters, call
from ..statement import Hamiltonian, OptimalControlProblem
from ..statement.symbols import column

CONTROL_SETS = ("box", "ball")


@dataclass
class SwitchingGroup:
    """Controls ``indices`` given by ``controls[regime]`` where ``regime = #{k : quantity > thresholds[k]}``."""

    quantity: ca.SX
    thresholds: list[Any]
    controls: list[Any]
    indices: tuple[int, ...]

    def __post_init__(self) -> None:
        if len(self.controls) != len(self.thresholds) + 1:
            raise ValueError("a switching group needs one control branch more than it has thresholds")


@dataclass
class ControlLaw:
    """A piecewise-smooth minimiser of H: switching groups over the control vector (see module docstring).

    ``control_set`` is ``"box"``, ``"ball"`` or ``"user"``: a law of the user's, one group
    without thresholds (one smooth mode, no switching function).
    """

    groups: list[SwitchingGroup]
    nu: int
    regularized: bool
    control_set: str
    description: str = ""
    hamiltonian: Hamiltonian | None = field(default=None, repr=False)
    """The problem's Hamiltonian; the law's expressions are in its symbols ``x, p, P``."""
    radius: float | None = None
    """The ball's radius (``control_set="ball"``), else None."""

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

    def mode_of(self, regimes: Sequence[int]) -> int:
        mode, stride = 0, 1
        for r, size in zip(regimes, self.group_sizes):
            mode += r * stride
            stride *= size + 1
        return mode

    def control(self, mode: int) -> ca.SX:
        """The control branch (SX in the law's x, p, P) of a mode."""
        u: list[Any] = [None] * self.nu
        for g, r in zip(self.groups, self.regimes(mode)):
            branch = g.controls[r]
            for j, i in enumerate(g.indices):
                u[i] = branch[j] if branch.numel() > 1 else branch
        return ca.vertcat(*u)

    def switching(self) -> ca.SX:
        """All switching functions ``g_k = q - c_k`` (SX in x, p, P)."""
        return ca.vertcat(ca.SX(0, 1), *[g.quantity - c for g in self.groups for c in g.thresholds])


def control_law(
    problem: OptimalControlProblem,
    control_set: str | Callable[..., Any] = "box",
    *,
    regularized: bool = False,
    radius: float = 1.0,
) -> ControlLaw:
    """The minimiser of the problem's Hamiltonian ``H = L + p'f``: derived for an L1 or regularised cost, or given.

    Parameters
    ----------
    problem : OptimalControlProblem
        Autonomous; its running cost (0 without one) and dynamics give H (parameters stay symbolic).
    control_set : str or callable
        ``"box"`` (each control within its bounds, which must contain 0) or ``"ball"``
        (``|u| <= radius``): the law is derived (see the module docstring); or a callable
        ``u_star``: a law of your own (Notes).
    regularized : bool
        False: bang-off-bang (the quadratic coefficient ``b`` must vanish; a box control
        needs finite bounds). True: saturated linear law for ``b >= 0``, valid for every
        homotopy parameter including the L1 end, where its linear regimes have zero width;
        an unbounded side of a box is never saturated (then ``b > 0`` is required).
    radius : float
        The radius of the ``"ball"`` control set.

    Notes
    -----
    A law of your own, ``control_law(problem, u_star)``: ``u_star(x, p)`` -- or
    ``u_star(x, p, params)`` to receive the problem's parameters by name, as its dynamics
    do (:mod:`ocpkit.names`) -- is called once, on CasADi columns ``x`` and ``p`` of ``nx``
    symbols each (named by the states: ``x["m"]``, ``p["m"]``), and returns the minimising control::

        u*(x, p) = argmin_{u in U} H(x, p, u)

    as CasADi expressions: one expression (``nu = 1``), a list of ``nu`` or a column
    (``ca.vertcat``), written with CasADi's functions (``ca.atan2``, ``ca.fmin``). A
    numpy array, a ``math`` function (NaN on a symbol), another number of controls than
    ``nu``, a law depending on other symbols, or one finite nowhere, is an error naming
    the law. The flow is that of Pontryagin's principle at ``u = u*(x, p)``:
    ``dx/dt = f(x, u*)``, ``dp/dt = -dH/dx (x, p, u*)`` (the partial derivative at fixed u);
    the law is one smooth mode with no switching function, so the integrator's detection
    options change nothing. That ``u*`` minimises H (not maximises; within the bounds) is
    the user's to ensure: the law is not checked against H. Examples: ``u* = -p_v`` for
    ``L = u^2 / 2`` and ``dv/dt = u``; ``u* = atan2(-(v p_y + g p_v), -v p_x)`` for the
    brachistochrone ``(x, y, v)' = (v cos u, v sin u, g sin u)``.
    """
    if callable(control_set):
        if regularized or radius != 1.0:
            raise ValueError("regularized and radius apply to the derived box and ball laws, not to a law of your own")
        return _user_law(problem, control_set)
    if control_set not in CONTROL_SETS:
        raise ValueError(f"control_set must be one of {CONTROL_SETS} or a control law u_star, got {control_set!r}")
    nu = problem.nu
    if nu == 0:
        raise ValueError("the problem has no controls")
    ham = problem.functions.hamiltonian
    u, H = ham.u, ham.H
    _require_autonomous(ham)
    _, psi, w, b = decompose(H, u, nu)
    unbounded = []
    if control_set == "box":
        unbounded = [i for i, c in enumerate(problem.controls) if not (np.isfinite(c.lower) and np.isfinite(c.upper))]
    # the form first: an H this law cannot minimise is the error, whatever the bounds
    _check_form(problem, ham, control_set, regularized, psi, w, b, unbounded)
    groups: list[SwitchingGroup] = []
    branches: list[Any]
    if control_set == "box":
        for i, c in enumerate(problem.controls):
            lo, hi = c.lower, c.upper
            if not lo <= 0.0 <= hi:
                raise ValueError(f"box control {c.name!r} needs bounds around 0, got [{lo}, {hi}]")
            q = psi[i]
            if regularized:
                # saturation at a finite bound only: u = -(q +- w) / (2 b) never reaches an infinite one
                top = [(-w[i] - 2 * b[i] * hi, ca.SX(hi))] if np.isfinite(hi) else []
                bottom = [(w[i] - 2 * b[i] * lo, ca.SX(lo))] if np.isfinite(lo) else []
                thresholds = [t for t, _ in top] + [-w[i], w[i]] + [t for t, _ in bottom]
                linear = [-(q + w[i]) / (2 * b[i]), ca.SX(0), -(q - w[i]) / (2 * b[i])]
                branches = [br for _, br in top] + linear + [br for _, br in bottom]
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
    return ControlLaw(groups, nu, regularized, control_set, description, ham, radius if control_set == "ball" else None)


def _require_autonomous(ham: Hamiltonian) -> None:
    if ca.depends_on(ca.vertcat(ham.f, ham.L), ham.t):
        raise ValueError("indirect shooting here needs an autonomous problem (no explicit time dependence)")


def _user_law(problem: OptimalControlProblem, u_star: Callable[..., Any], samples: int = 5) -> ControlLaw:
    """The law ``u_star(x, p[, params])`` of the user, as one smooth mode (see :func:`control_law`)."""
    name = getattr(u_star, "__name__", type(u_star).__name__)
    what = f"control law {name!r}"
    nu, nx = problem.nu, problem.nx
    if nu == 0:
        raise ValueError("the problem has no controls")
    ham = problem.functions.hamiltonian
    _require_autonomous(ham)
    names = problem.state_names
    inputs = [Named(ham.x, names, "state", "x"), Named(ham.p, names, "costate", "p")]
    params = NamedParameters(ham.P, problem.parameter_names)
    u = column(call(u_star, inputs, params, has_parameters=problem.takes_parameters, what=what), what)
    if u.shape != (nu, 1):
        raise ValueError(
            f"{what} returned shape {u.shape}, expected ({nu}, 1): one expression per control {problem.control_names}"
        )
    try:
        ufun = ca.Function("u_star", [ham.x, ham.p, ham.P], [u])
    except RuntimeError:
        raise ValueError(f"{what} depends on symbols other than its arguments x, p and the parameters") from None
    rng = np.random.default_rng(0)
    xs = np.array([sample_value(s) for s in problem.states])
    pv = problem.parameter_values
    if not any(np.all(np.isfinite(np.asarray(ufun(xs, rng.normal(size=nx), pv)))) for _ in range(samples)):
        raise ValueError(
            f"{what} is not finite at any sampled (x, p): a math or numpy function (math.atan2, np.sqrt) applied to "
            "a CasADi symbol gives NaN; use CasADi's (ca.atan2, ca.sqrt)"
        )
    group = SwitchingGroup(ca.SX(0), [], [u], tuple(range(nu)))
    return ControlLaw([group], nu, False, "user", f"user law {name}", ham)


def _check_form(
    problem: OptimalControlProblem,
    ham: Hamiltonian,
    control_set: str,
    regularized: bool,
    psi: list[ca.SX],
    w: list[ca.SX],
    b: list[ca.SX],
    unbounded: Sequence[int] = (),
    samples: int = 20,
    tol: float = 1e-8,
) -> None:
    """H must equal H0 + psi.u + w|u| + b|u|^2 (b = 0 unless regularised, b > 0 on unbounded controls).

    Raise ValueError otherwise, saying what is wrong: a Hamiltonian of another form needs
    a law of the user's; an unbounded box control needs a positive quadratic cost.
    """
    x, p, P, u, H = ham.x, ham.p, ham.P, ham.u, ham.H
    nu = problem.nu
    if control_set == "box":
        model = sum(psi[i] * u[i] + w[i] * ca.fabs(u[i]) + b[i] * u[i] ** 2 for i in range(nu))
    else:
        model = ca.dot(ca.vertcat(*psi), u) + w[0] * ca.norm_2(u) + b[0] * ca.sumsqr(u)
    H0 = ca.substitute(H, u, ca.DM.zeros(nu))
    residual = ca.Function("residual", [x, p, u, P], [H - H0 - model])
    hfun = ca.Function("h", [x, p, u, P], [H])
    bfun = ca.Function("b", [x, p, P], [ca.vertcat(*b)])
    rng = np.random.default_rng(0)
    pv = problem.parameter_values
    names = [problem.controls[i].name for i in unbounded]
    for _ in range(samples):
        xs = np.array([sample_value(s) for s in problem.states])
        ps = rng.normal(size=problem.nx)
        us = rng.uniform(-1, 1, size=nu)
        r = abs(float(residual(xs, ps, us, pv)))
        if r > tol * (1 + abs(float(hfun(xs, ps, us, pv)))):
            free = f", and {', '.join(names)} {'is' if len(names) == 1 else 'are'} unbounded" if names else ""
            raise ValueError(
                "a control law is needed: the Hamiltonian is not of the form H0 + psi.u + w|u| + b|u|^2 that the "
                f"{control_set} laws minimise (u enters it otherwise, through cos u, u^4, ...){free}; pass the "
                "minimising control yourself, control_law(problem, u_star) with u_star(x, p) returning CasADi "
                "expressions"
            )
        bs = np.asarray(bfun(xs, ps, pv)).ravel()
        if not regularized and np.abs(bs).max() > tol:
            raise ValueError("the cost has a quadratic control term: use regularized=True")
        for i in unbounded:
            c = problem.controls[i]
            if not regularized:
                raise ValueError(
                    f"box control {c.name!r} is unbounded ([{c.lower}, {c.upper}]) and H is affine in it (an L1 "
                    "cost or none): H has no minimum over an unbounded control; give it finite bounds"
                )
            if not bs[i] > tol:
                raise ValueError(
                    f"box control {c.name!r} is unbounded ([{c.lower}, {c.upper}]) and the quadratic coefficient "
                    f"of H in it is {bs[i]:g}, not positive: H has no minimum; give it finite bounds"
                )


class HamiltonianSystem:
    """The mode-wise Hamiltonian flows of a problem and a control law, as CasADi functions.

    ``y = (x, p, J)`` of dimension ``n = 2 nx + 1``, where ``dJ/dt = l(x, u)`` accumulates
    the running cost; ``P`` the problem's parameter vector.

    * ``flow(y, mode, P) -> dy/dt`` and, for ``mode`` given as the regimes' mixed
      radix index, the same for every mode through a switch;
    * ``switching(y, P) -> g`` and ``dswitch(y, P) -> dg/dy``;
    * ``hamiltonian(y, mode, P) -> H``, ``control(y, mode, P) -> u``;
    * ``varflow(y, Psi, mode, P) -> (dy/dt, dPsi/dt)`` with ``dPsi/dt = (d phi_mode / dy) Psi``;
    * ``acceleration(y, mode, P) -> d2y/dt2``.
    """

    def __init__(self, problem: OptimalControlProblem, law: ControlLaw, n_variational: int | None = None) -> None:
        self.problem, self.law = problem, law
        nx = problem.nx
        self.nx, self.n = nx, 2 * nx + 1
        self.n_variational = nx if n_variational is None else int(n_variational)
        # the flows are those of the Hamiltonian the law minimises (control_law's laws carry it)
        law_ham = cast(Hamiltonian, law.hamiltonian)
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
        #: ``flow(y, mode, P) -> dy/dt``, ``mode`` the regimes' mixed radix index (every mode through a switch)
        self.flow = ca.Function("ocp_flow", [y, mode, P], [sel(mode, flows, zero_phi)], ["y", "mode", "P"], ["ydot"])
        #: ``hamiltonian(y, mode, P) -> H``
        self.hamiltonian = ca.Function("ocp_ham", [y, mode, P], [sel(mode, hams, ca.SX(0))], ["y", "mode", "P"], ["H"])
        #: ``control(y, mode, P) -> u``
        self.control = ca.Function(
            "ocp_control", [y, mode, P], [sel(mode, ctrls, ca.SX.zeros(law.nu))], ["y", "mode", "P"], ["u"]
        )
        g = law.switching()
        #: ``switching(y, P) -> g``, the switching functions
        self.switching = ca.Function("ocp_switching", [y, P], [g], ["y", "P"], ["g"])
        #: ``dswitch(y, P) -> dg/dy``
        self.dswitch = ca.Function("ocp_dswitch", [y, P], [ca.densify(ca.jacobian(g, y))], ["y", "P"], ["dg"])
        #: ``varflow(y, Psi, mode, P) -> (dy/dt, dPsi/dt)`` with ``dPsi/dt = (d phi_mode / dy) Psi``
        self.varflow = ca.Function(
            "ocp_varflow",
            [y, Psi, mode, P],
            [sel(mode, flows, zero_phi), sel(mode, varflows, ca.SX.zeros(self.n, self.n_variational))],
            ["y", "Psi", "mode", "P"],
            ["ydot", "Psidot"],
        )
        self._branches = (y, Psi, P, flows, varflows, hams)
        self._mode = mode

    @functools.cached_property
    def acceleration(self) -> ca.Function:
        """``acceleration(y, mode, P) -> d2y/dt2 = (d phi_mode / dy) phi_mode`` (the dense output's second
        derivative; built when first asked for)."""
        y, _, P, flows, _, _ = self._branches
        second = [ca.jtimes(phi, y, phi) for phi in flows]
        out = ca.conditional(self._mode, second, ca.SX.zeros(self.n))
        return ca.Function("ocp_acceleration", [y, self._mode, P], [out], ["y", "mode", "P"], ["yddot"])

    def compiled_functions(self) -> list[ca.Function]:
        """The functions the C integrator calls: flow, varflow, switching, dswitch, hamiltonian.

        Same names and signatures as :attr:`flow`, :attr:`varflow`, ... but the
        mode selects its branch through a C ``switch`` (``Function.conditional``),
        so each call evaluates one mode; an SX ``conditional`` evaluates every branch.
        """
        y, Psi, P, flows, varflows, hams = self._branches
        mode = ca.MX.sym("mode")

        def switched(
            name: str,
            sx_inputs: list[ca.SX],
            branches: Sequence[Sequence[ca.SX]],
            names_in: list[str],
            names_out: list[str],
        ) -> ca.Function:
            per_mode = [ca.Function(f"{name}_{m}", sx_inputs, list(b)) for m, b in enumerate(branches)]
            zero = ca.Function(f"{name}_none", sx_inputs, [ca.SX.zeros(o.sparsity()) for o in branches[0]])
            select = ca.Function.conditional(f"{name}_switch", per_mode, zero)
            mx = [ca.MX.sym(n, s.sparsity()) for n, s in zip([n for n in names_in if n != "mode"], sx_inputs)]
            out: Any = select(mode, *mx)  # one output: an MX; several: a tuple of them
            out = out if isinstance(out, (list, tuple)) else [out]
            inputs = mx[:-1] + [mode, mx[-1]]  # (..., mode, P), as the SX functions
            return ca.Function(name, inputs, list(out), names_in, names_out)

        flow = switched("ocp_flow", [y, P], [(phi,) for phi in flows], ["y", "mode", "P"], ["ydot"])
        varflow = switched(
            "ocp_varflow", [y, Psi, P], list(zip(flows, varflows)), ["y", "Psi", "mode", "P"], ["ydot", "Psidot"]
        )
        ham = switched("ocp_ham", [y, P], [(h,) for h in hams], ["y", "mode", "P"], ["H"])
        return [flow, varflow, self.switching, self.dswitch, ham]

    def mode_at(self, y: np.ndarray, P: np.ndarray) -> int:
        """The mode selected by the signs of the switching functions at ``y``."""
        g = np.asarray(self.switching(y, P)).ravel()
        regimes, k = [], 0
        for size in self.law.group_sizes:
            regimes.append(int(np.sum(g[k : k + size] > 0)))
            k += size
        return self.law.mode_of(regimes)
