"""Where the two-timescale scheme pays: the attitude ascent, a problem with real timescale separation (notebook 08).

A *design* is how the two-timescale scheme is used on the problem: which states are fast, the coupling
(``coupling`` of :class:`ocpkit.MultiRateHLGL`) and where the controls live (``control_mesh``). Every
design is compared with standard HLGL on the same fine mesh (``fine_segments``; the design's coarse mesh has
``fine_segments / M`` segments) against one converged reference solution.

Errors are relative, per group of states: the largest over the group's states of ``max |x - x_ref| /
max(1, max |x_ref|)`` on a common normalised time grid; the control's is ``max |u - u_ref| / max |u_ref|``.
Times are not computed here (they differ from run to run): ``benchmarks/bench_fast_slow.py`` measures them for
the same designs and meshes and :func:`with_measured_times` joins its table.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.ticker import NullFormatter

from ocpkit import HLGL, MultiRateHLGL, OptimalControlProblem

from .. import paths

#: The designs compared (label -> MultiRateHLGL options); "standard" is HLGL on the fine mesh.
DESIGNS: dict[str, dict] = {
    "paper's design, attitude fast": {
        "fast": ("theta", "q"),
        "coupling": "coarse",
        "control_mesh": "coarse",
    },
    "Galerkin, attitude fast": {
        "fast": ("theta", "q"),
        "coupling": "galerkin",
        "control_mesh": "fine",
    },
    "Galerkin, positions slow": {
        "fast": ("U", "V", "theta", "q"),
        "coupling": "galerkin",
        "control_mesh": "fine",
    },
}
STANDARD = "standard"

#: The groups of states whose errors are reported
STATE_GROUPS: dict[str, tuple[str, ...]] = {
    "positions": ("X", "Y"),
    "velocities": ("U", "V"),
    "attitude": ("theta", "q"),
}

#: The committed times of ``benchmarks/bench_fast_slow.py --publish``
MEASURED_TIMES = "data/benchmarks/fast_slow.csv"
KEYS = ["design", "ratio", "fine_segments"]


def transcription(problem: OptimalControlProblem, design: str, fine_segments: int, ratio: int = 1):
    """The transcription of ``design`` (a key of :data:`DESIGNS`, or :data:`STANDARD`) on ``fine_segments``."""
    if design == STANDARD:
        return HLGL(problem, fine_segments)
    if design not in DESIGNS:
        raise ValueError(f"unknown design {design!r}; designs are {[STANDARD, *DESIGNS]}")
    if fine_segments % ratio:
        raise ValueError(f"fine_segments ({fine_segments}) must be a multiple of the ratio ({ratio})")
    options = dict(DESIGNS[design])
    fast = list(options.pop("fast"))
    return MultiRateHLGL(problem, fine_segments // ratio, ratio=ratio, fast=fast, **options)


def errors_against(solution, reference, groups: Mapping[str, Sequence[str]] = STATE_GROUPS, n: int = 8001) -> dict:
    """Relative errors of ``solution`` against ``reference`` per group of states and of the control (module
    docstring), and the absolute error of t_f."""
    s = np.linspace(0.0, 1.0, n)
    names = reference.problem.state_names
    x = solution.state(solution.t0 + s * (solution.tf - solution.t0))
    x_ref = reference.state(reference.t0 + s * (reference.tf - reference.t0))
    rel = np.abs(x - x_ref).max(axis=0) / np.maximum(1.0, np.abs(x_ref).max(axis=0))
    out = {f"{g}_error": float(max(rel[names.index(v)] for v in states)) for g, states in groups.items()}
    u = solution.control(solution.t0 + s * (solution.tf - solution.t0))
    u_ref = reference.control(reference.t0 + s * (reference.tf - reference.t0))
    out["control_error"] = float(np.abs(u - u_ref).max() / max(np.abs(u_ref).max(), np.finfo(float).tiny))
    out["tf_error"] = float(abs(solution.tf - reference.tf))
    return out


def accuracy_study(
    problem: OptimalControlProblem,
    reference,
    fine_segments: Sequence[int],
    ratios: Sequence[int],
    designs: Sequence[str] = tuple(DESIGNS),
    *,
    ipopt_options: dict | None = None,
    n: int = 8001,
) -> pd.DataFrame:
    """Every design at every ratio, and standard HLGL, on every fine mesh: sizes, iterations and errors.

    One row per solve: ``design, ratio, coarse_segments, fine_segments, nlp_parameters, defect_equations,
    iterations`` and the errors of :func:`errors_against`.
    """
    rows = []
    runs = [(STANDARD, 1)] + [(d, int(m)) for d in designs for m in ratios]
    for fine in fine_segments:
        for design, ratio in runs:
            sol = transcription(problem, design, int(fine), ratio).solve(ipopt_options=ipopt_options)
            rows.append(
                {
                    "design": design,
                    "ratio": ratio,
                    "coarse_segments": int(fine) // ratio,
                    "fine_segments": int(fine),
                    "nlp_parameters": sol.decision_variables,
                    "defect_equations": sol.defect_equations,
                    "iterations": sol.iterations,
                    **errors_against(sol, reference, n=n),
                }
            )
    return pd.DataFrame(rows)


def measured_times(path=None) -> pd.DataFrame:
    """The committed table of ``benchmarks/bench_fast_slow.py --publish`` (build, solve, end-to-end seconds)."""
    return pd.read_csv(paths.repo_root() / MEASURED_TIMES if path is None else path)


def with_measured_times(study: pd.DataFrame, times: pd.DataFrame, effort_weight: float, ipopt_tol: float):
    """``study`` with the measured ``end_to_end_s`` of the same design, ratio and fine mesh, for the same
    ``effort_weight`` and IPOPT tolerance (NaN where the benchmark did not run that case).

    The times must be of the same NLPs (an error otherwise) and of the same solves: a warning names the cases
    whose IPOPT iterations differ (another machine's rounding can change a count)."""
    same = np.isclose(times.effort_weight, effort_weight, rtol=1e-12, atol=0.0)
    same &= np.isclose(times.ipopt_tol, ipopt_tol, rtol=1e-12, atol=0.0)
    t = times.loc[same, KEYS + ["nlp_parameters", "iterations", "end_to_end_s"]]
    t = t.rename(columns={"nlp_parameters": "measured_nlp_parameters", "iterations": "measured_iterations"})
    out = study.merge(t, on=KEYS, how="left", validate="one_to_one")
    measured = out.measured_nlp_parameters.notna()
    wrong = out[measured & (out.measured_nlp_parameters != out.nlp_parameters)]
    if len(wrong):
        raise ValueError(f"the measured times are of other NLPs: {wrong[KEYS].to_dict('records')}")
    other = out[measured & (out.measured_iterations != out.iterations)]
    if len(other):
        warnings.warn(
            f"the measured times of {len(other)} cases are of solves with other IPOPT iteration counts: "
            f"{other[KEYS].to_dict('records')}",
            stacklevel=2,
        )
    return out.drop(columns=["measured_nlp_parameters", "measured_iterations"])


def cost_to_reach(study: pd.DataFrame, error: str, target: float, cost: str) -> pd.DataFrame:
    """Per design and ratio, the ``cost`` (a column: NLP parameters, seconds) at which ``error`` reaches
    ``target``: interpolated log-log between the two meshes that bracket it; NaN where no two meshes of the study
    bracket it (never reached, or already reached on the coarsest)."""
    rows = []
    for (design, ratio), g in study.groupby(["design", "ratio"], sort=False):
        g = g.sort_values("fine_segments")
        e, c = g[error].to_numpy(float), g[cost].to_numpy(float)
        value = np.nan
        for k in range(len(g)):
            if e[k] <= target:
                if k == 0:
                    value = c[0] if e[0] == target else np.nan
                else:
                    w = np.log(target / e[k - 1]) / np.log(e[k] / e[k - 1])
                    value = float(np.exp(np.log(c[k - 1]) + w * (np.log(c[k]) - np.log(c[k - 1]))))
                break
        rows.append({"design": design, "ratio": ratio, f"{cost}_to_reach": value})
    return pd.DataFrame(rows)


def accuracy_cost_figure(study: pd.DataFrame, errors: Sequence[tuple[str, str]], costs: Sequence[tuple[str, str]]):
    """Error against cost, one curve per design and ratio: a row of panels per error, a column per cost.

    ``errors`` and ``costs``: ``(column, axis label)`` pairs. Standard HLGL is black; each design has a colour,
    each ratio a marker.
    """
    designs = [d for d in study.design.unique() if d != STANDARD]
    colours = dict(zip(designs, ["tab:orange", "tab:blue", "tab:green", "tab:red", "tab:purple"]))
    markers = dict(zip(sorted(study.ratio.unique()), ["o", "s", "^", "D", "v", "P"]))
    fig, axes = plt.subplots(
        len(errors),
        len(costs),
        figsize=(4.6 * len(costs) + 3.2, 3.4 * len(errors)),
        layout="constrained",
        squeeze=False,
    )
    for i, (err, err_label) in enumerate(errors):
        for j, (cost, cost_label) in enumerate(costs):
            ax = axes[i, j]
            for (design, ratio), g in study.groupby(["design", "ratio"], sort=False):
                g = g.dropna(subset=[cost]).sort_values("fine_segments")
                if g.empty:
                    continue
                standard = design == STANDARD
                ax.loglog(
                    g[cost],
                    g[err],
                    color="black" if standard else colours[design],
                    marker="o" if standard else markers[ratio],
                    lw=2.0 if standard else 1.2,
                    ms=4,
                    label="standard HLGL" if standard else f"{design}, M = {ratio}",
                )
            ax.set_xlabel(cost_label)
            ax.set_ylabel(err_label)
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.grid(True, which="major", alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside right upper", fontsize=8)
    return fig
