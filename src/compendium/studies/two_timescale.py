"""Standard versus two-timescale collocation: the rows of Desai & Conway's Tables 1-2 and studies beyond them."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from ocpkit import HLGL, MultiRateHLGL, OptimalControlProblem

from ..checks import approx

TABLE_COLUMNS = [
    "scheme",
    "segments",
    "nlp_parameters",
    "defect_equations",
    "iterations",
    "max_state_diff_pct",
    "max_control_diff_pct",
    "build_s",
    "solve_s",
]


def _row(scheme: str, segments: str, solution, diff: dict | None) -> dict:
    return {
        "scheme": scheme,
        "segments": segments,
        "nlp_parameters": solution.decision_variables,
        "defect_equations": solution.defect_equations,
        "iterations": solution.iterations,
        "max_state_diff_pct": diff["states"] if diff else float("nan"),
        "max_control_diff_pct": diff["controls"] if diff else float("nan"),
        "build_s": solution.build_s,
        "solve_s": solution.solve_s,
    }


def compare_case(
    problem: OptimalControlProblem,
    coarse_segments: int,
    ratio: int,
    fast: Sequence[str],
    scheme: str,
    *,
    coupling: str = "coarse",
    ipopt_options: dict | None = None,
    n: int = 2001,
):
    """Solve the standard mesh (coarse x ratio segments) and the two-timescale scheme from the same guess.

    Returns ``(table, standard, two_timescale)``: a two-row DataFrame with
    :data:`TABLE_COLUMNS` (differences of the two-timescale solution from the
    standard one, :meth:`ocpkit.trajectory.Trajectory.difference`) and both solutions.
    """
    standard = HLGL(problem, coarse_segments * ratio).solve(ipopt_options=ipopt_options)
    mr = MultiRateHLGL(problem, coarse_segments, ratio=ratio, fast=fast, coupling=coupling)
    two = mr.solve(ipopt_options=ipopt_options)
    diff = two.difference(standard, n)
    rows = [
        _row("standard", str(coarse_segments * ratio), standard, None),
        _row(scheme, f"{coarse_segments}/{coarse_segments * ratio}", two, diff),
    ]
    return pd.DataFrame(rows, columns=TABLE_COLUMNS), standard, two


def side_by_side(paper: pd.DataFrame, ours: pd.DataFrame) -> pd.DataFrame:
    """Paper and compendium values next to each other, matched on the ``scheme`` column."""
    p = paper.set_index("scheme")
    o = ours.set_index("scheme")
    missing = sorted(set(p.index) - set(o.index))
    if missing:
        raise KeyError(f"schemes {missing} of the paper have no computed row")
    out = pd.DataFrame({"segments": p["segments"]})
    for col, ours_label in (
        ("nlp_parameters", "nlp_parameters"),
        ("defect_equations", "defect_equations"),
        ("iterations", "iterations (IPOPT)"),
        ("max_state_diff_pct", "max_state_diff_pct"),
        ("max_control_diff_pct", "max_control_diff_pct"),
    ):
        out[f"{col} paper"] = p[col]
        out[f"{ours_label} ours"] = o.loc[p.index, col]
    return out.reset_index()


def ratio_study(
    problem: OptimalControlProblem,
    coarse_segments: int,
    ratios: Sequence[int],
    fast: Sequence[str],
    reference,
    *,
    coupling: str = "coarse",
    ipopt_options: dict | None = None,
    n: int = 2001,
) -> pd.DataFrame:
    """NLP size and accuracy of the two-timescale scheme versus the ratio M (fixed coarse mesh).

    Each row compares the two-timescale solution with the standard solution on
    the same fine mesh (``diff_vs_standard``) and with a converged ``reference``
    solution (``error_vs_reference``), in percent.
    """
    rows = []
    for M in ratios:
        table, standard, two = compare_case(
            problem,
            coarse_segments,
            int(M),
            fast,
            "two_timescale",
            coupling=coupling,
            ipopt_options=ipopt_options,
            n=n,
        )
        err = two.difference(reference, n)
        err_std = standard.difference(reference, n)
        rows.append(
            {
                "coupling": coupling,
                "coarse_segments": coarse_segments,
                "ratio": int(M),
                "nlp_parameters": two.decision_variables,
                "standard_nlp_parameters": standard.decision_variables,
                "iterations": two.iterations,
                "state_diff_vs_standard_pct": table.loc[1, "max_state_diff_pct"],
                "control_diff_vs_standard_pct": table.loc[1, "max_control_diff_pct"],
                "state_error_vs_reference_pct": err["states"],
                "control_error_vs_reference_pct": err["controls"],
                "standard_control_error_vs_reference_pct": err_std["controls"],
                "tf_minus_reference": two.tf - reference.tf,
            }
        )
    return pd.DataFrame(rows)


def segments_study(
    problem: OptimalControlProblem,
    coarse_segments: Sequence[int],
    ratio: int,
    fast: Sequence[str],
    reference,
    **kwargs,
) -> pd.DataFrame:
    """:func:`ratio_study` at a fixed ratio for several coarse meshes."""
    return pd.concat(
        [ratio_study(problem, int(n), [ratio], fast, reference, **kwargs) for n in coarse_segments],
        ignore_index=True,
    )


#: display formats of the side-by-side tables
SIDE_BY_SIDE_FORMATS = {
    "max_state_diff_pct paper": ".2g",
    "max_state_diff_pct ours": ".2g",
    "max_control_diff_pct paper": ".2g",
    "max_control_diff_pct ours": ".2g",
}


def paper_case(
    problem: OptimalControlProblem,
    name: str,
    coarse_segments: int,
    ratio: int,
    fast: Sequence[str],
    scheme: str,
    *,
    coupling: str = "coarse",
    ipopt_options: dict | None = None,
    n: int = 2001,
    outputs=None,
):
    """One of Desai & Conway's tables (``name``: ``"table1"``, ``"table2"``), computed and, given ``outputs``
    (a :class:`compendium.outputs.Outputs`), written.

    Writes ``data/derived/<name>.csv`` (our rows, without the measured times, which go to the run's
    timings) and ``<name>.md`` (paper beside ours). Returns ``(rows, side_by_side, standard, two_timescale)``.
    """
    from ..paper import paper_source, paper_table
    from ..tables import markdown_table

    rows, standard, two = compare_case(
        problem,
        coarse_segments,
        ratio,
        fast,
        scheme,
        coupling=coupling,
        ipopt_options=ipopt_options,
        n=n,
    )
    both = side_by_side(paper_table(name), rows)
    if outputs is not None:
        timing = ["build_s", "solve_s"]
        outputs.table(rows.drop(columns=timing), name, "%.6g")
        outputs.timing(name, rows[["scheme", *timing]])
        source = paper_source(name).splitlines()
        header = f"<!-- written by notebooks/02_two_timescale.ipynb -->\n\nPaper values: {source[0]} {source[1]}\n\n"
        outputs.text(header + markdown_table(both, SIDE_BY_SIDE_FORMATS) + "\n", f"{name}.md")
    return rows, both, standard, two


def verdict_lines(rows: pd.DataFrame, paper: pd.DataFrame) -> list[str]:
    """Sizes and maximum differences of our rows against the paper's, one line each."""
    paper, ours = paper.set_index("scheme"), rows.set_index("scheme")
    scheme = ours.index[1]
    lines = []
    for col in ("nlp_parameters", "defect_equations"):
        lines.append(
            f"{col}: standard {ours.loc['standard', col]} (paper {paper.loc['standard', col]}), "
            f"{scheme} {ours.loc[scheme, col]} (paper {paper.loc[scheme, col]})"
        )
    for col in ("max_state_diff_pct", "max_control_diff_pct"):
        v, bound = ours.loc[scheme, col], paper.loc[scheme, col]
        lines.append(f"{col}: {approx(v, 1)} % (paper {bound} %), at or below the paper: {v <= bound}")
    return lines


def overlay_figure(problem: OptimalControlProblem, standard, two, title: str, n: int = 2001):
    """Standard and two-timescale histories overlaid (left) and their difference (right), in normalised time."""
    import matplotlib.pyplot as plt
    import numpy as np

    s = np.linspace(0, 1, n)
    ts, tt = s * standard.tf, s * two.tf
    xs, xt = standard.state(ts), two.state(tt)
    us, ut = standard.control(ts), two.control(tt)
    names = problem.state_names + problem.control_names
    fig, axes = plt.subplots(len(names), 2, figsize=(8.5, 9.5), sharex=True, layout="constrained")
    for j, var in enumerate(names):
        a, b = (xs[:, j], xt[:, j]) if j < problem.nx else (us[:, 0], ut[:, 0])
        axes[j, 0].plot(ts, a, label="standard")
        axes[j, 0].plot(tt, b, "--", label="two-timescale")
        axes[j, 0].set_ylabel(var if var != "theta" else r"$\theta$ (rad)")
        axes[j, 1].plot(ts, 100 * (b - a) / np.abs(a).max(), color="C1")
        axes[j, 1].set_ylabel("diff. (% of max)")
    axes[0, 0].legend()
    axes[0, 0].set_title("histories")
    axes[0, 1].set_title("two-timescale minus standard")
    for ax in axes[-1]:
        ax.set_xlabel("t (non-dimensional)")
    fig.suptitle(title)
    return fig


#: The NLP solvers of the iteration study: IPOPT with its exact (assembled) Hessian, IPOPT with an L-BFGS
#: approximation, and SciPy's SLSQP (dense SQP with a BFGS Hessian: the class of the paper's era)
QUASI_NEWTON_SOLVERS = ("IPOPT, exact Hessian", "IPOPT, L-BFGS Hessian", "SLSQP, BFGS Hessian")


def solve_with(transcription, solver: str, tol: float):
    """One solve of ``transcription`` from the data file's guess with one of :data:`QUASI_NEWTON_SOLVERS`.

    ``tol``: IPOPT's ``tol`` (exact Hessian); the quasi-Newton solvers stop at ``max(tol, 1e-8)`` (IPOPT) or
    an objective change of ``1e-12`` (SLSQP), as tight as they converge.
    """
    from ocpkit.nlp import solve_nlp_slsqp

    if solver == QUASI_NEWTON_SOLVERS[0]:
        return transcription.solve(ipopt_options={"tol": tol}, error_threshold=None)
    if solver == QUASI_NEWTON_SOLVERS[1]:
        options = {"tol": max(tol, 1e-8), "hessian_approximation": "limited-memory", "max_iter": 5000}
        return transcription.solve(ipopt_options=options, error_threshold=None)
    if solver == QUASI_NEWTON_SOLVERS[2]:
        lbw, ubw, lbg, ubg = transcription.nlp_bounds()
        result = solve_nlp_slsqp(transcription.nlp, transcription.initial_point(), lbw, ubw, lbg, ubg)
        return transcription.package(result)
    raise ValueError(f"solver must be one of {QUASI_NEWTON_SOLVERS}, got {solver!r}")


def iteration_study(problem, rows, solvers=QUASI_NEWTON_SOLVERS, tol: float = 1e-13) -> pd.DataFrame:
    """Iterations and solve time of each of Tables 1-2's rows under each solver, from the same guess.

    ``rows``: ``(table, scheme, segments_label, make_transcription)``. Columns: the row, ``nlp_parameters``,
    ``solver``, ``iterations``, ``solve_s`` and ``tf`` (every row must reach the same optimum as the exact
    Newton solve of its NLP).
    """
    out = []
    for table, scheme, segments, make in rows:
        for solver in solvers:
            sol = solve_with(make(), solver, tol)
            out.append(
                {
                    "table": table,
                    "scheme": scheme,
                    "segments": segments,
                    "nlp_parameters": sol.decision_variables,
                    "solver": solver,
                    "iterations": sol.iterations,
                    "solve_s": sol.solve_s,
                    "tf": sol.tf,
                }
            )
    return pd.DataFrame(out)


def order_study(problem, cases, coarse_segments, reference, *, ipopt_options=None, n: int = 2001) -> pd.DataFrame:
    """Control and state errors against ``reference`` on refined coarse meshes, and their least-squares orders.

    ``cases``: label -> ``dict(fast=..., ratio=..., coupling=...)`` of :class:`ocpkit.MultiRateHLGL`;
    an empty ``fast`` is standard HLGL on the same fine mesh (``segments * ratio``). One row per case: the
    errors (absolute, max over the normalised grid) per coarse mesh and the orders.
    """
    from ocpkit.analysis import convergence_order

    rows = []
    t = np.linspace(0.0, 1.0, n)
    for label, case in cases.items():
        fast, ratio = list(case["fast"]), int(case["ratio"])
        du, dx = [], []
        for segments in coarse_segments:
            if not fast:
                tr = HLGL(problem, segments * ratio)
            else:
                coupling = case.get("coupling", "coarse")
                tr = MultiRateHLGL(problem, segments, ratio=ratio, fast=fast, coupling=coupling)
            sol = tr.solve(ipopt_options=ipopt_options, error_threshold=None)
            du.append(float(np.abs(sol.control(t * sol.tf) - reference.control(t * reference.tf)).max()))
            dx.append(float(np.abs(sol.state(t * sol.tf) - reference.state(t * reference.tf)).max()))
        rows.append(
            {
                "case": label,
                **{f"control_error_{s}": e for s, e in zip(coarse_segments, du)},
                **{f"state_error_{s}": e for s, e in zip(coarse_segments, dx)},
                "control_order": convergence_order(coarse_segments, du),
                "state_order": convergence_order(coarse_segments, dx),
            }
        )
    return pd.DataFrame(rows)


def partition_study(problem, partitions, coarse_segments, ratio: int, reference, *, ipopt_options=None, n: int = 2001):
    """Where the order is lost: :func:`order_study` of several partitions into fast and slow states
    (``partitions``: label -> fast state names; none: standard HLGL), at one ratio, the paper's coupling.

    One row per partition: the control errors per coarse mesh and the control and state orders.
    """
    cases = {label: {"fast": fast, "ratio": ratio} for label, fast in partitions.items()}
    out = order_study(problem, cases, coarse_segments, reference, ipopt_options=ipopt_options, n=n)
    out.insert(1, "fast", [", ".join(f) if f else "(standard, fine mesh)" for f in partitions.values()])
    out = out.rename(columns={"case": "partition"})
    return out.drop(columns=[c for c in out.columns if c.startswith("state_error_")])


def coupling_study(
    problem,
    fast,
    ratios,
    couplings,
    coarse_segments,
    reference,
    *,
    standard_ratio: int = 2,
    ipopt_options=None,
    n: int = 2001,
) -> pd.DataFrame:
    """:func:`order_study` of one partition (``fast``) under each coupling (``coupling``) and ratio,
    and of standard HLGL on the fine meshes of ``standard_ratio``. Columns ``coupling`` and ``ratio`` name the
    case (``"standard"`` for HLGL)."""
    cases = {"standard": {"fast": [], "ratio": standard_ratio}}
    keys = [("standard", standard_ratio)]
    for ratio in ratios:
        for coupling in couplings:
            cases[f"{coupling}, M = {ratio}"] = {"fast": fast, "ratio": ratio, "coupling": coupling}
            keys.append((coupling, ratio))
    out = order_study(problem, cases, coarse_segments, reference, ipopt_options=ipopt_options, n=n)
    out.insert(1, "coupling", [k[0] for k in keys])
    out.insert(2, "ratio", [k[1] for k in keys])
    return out.drop(columns="case")


def coupling_explorer(
    problem,
    reference,
    *,
    segments: Sequence[int],
    ratios: Sequence[int],
    couplings: Sequence[str],
    partitions: dict,
    default: dict,
    first=None,
    ipopt_options=None,
    n: int = 2001,
):
    """The two-timescale scheme's choices in :func:`compendium.explorer.explore`: the coarse segments ``N``, the
    ratio ``M``, the coupling and the partition (``partitions``: label -> fast states; one without fast states, the
    standard scheme, is left out), each a drop-down; every combination is built once (``MultiRateHLGL``) and
    solved from the nearest solved one. ``default``: ``{"N", "M", "coupling", "fast"}`` of the first solution
    (added to the options where they lack it); ``first``: that solution, if solved already. Drawn: the control and
    its difference from ``reference`` at the same normalised time; the status line adds the NLP's size and the
    largest control difference (%, :meth:`ocpkit.trajectory.Trajectory.difference` on ``n`` points)."""
    from ..explorer import History, explore

    fast = {label: list(f) for label, f in partitions.items() if f}
    first_fast = list(default["fast"])
    label = next((k for k, f in fast.items() if f == first_fast), f"{', '.join(first_fast)} fast")
    fast.setdefault(label, first_fast)
    choices = {
        "N": sorted({*segments, default["N"]}),
        "M": sorted({*ratios, default["M"]}),
        "coupling": list(dict.fromkeys([*couplings, default["coupling"]])),
        "fast": fast,
    }
    control = problem.control_names[0]
    deg = 180.0 / np.pi

    def note(solution) -> str:
        error = solution.difference(reference, n)["controls"]
        return f"{solution.decision_variables} NLP parameters · control vs reference {error:.1e} %"

    return explore(
        lambda N, M, coupling, fast: MultiRateHLGL(problem, N, ratio=M, fast=fast, coupling=coupling),
        histories=[
            History(control, f"{control} (deg)", scale=deg),
            History.against(reference, control, f"{control} − reference (deg)", scale=deg, samples=n),
        ],
        choices=choices,
        defaults={"N": default["N"], "M": default["M"], "coupling": default["coupling"], "fast": label},
        first=first,
        solve_options={"ipopt_options": ipopt_options},
        note=note,
    )
