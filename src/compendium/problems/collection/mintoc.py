"""Reference-collection problems of mintOC, the benchmark library of mixed-integer optimal control problems (Sager
2012, https://mintoc.de); constants in ``data/problems/collection_mintoc.toml``, published values in
``data/paper/collection_mintoc.csv``.

Of the library's relaxed problems tried, only the batch reactor is kept. Lotka-Volterra fishing (relaxed optimum
1.34408, reached to 6 digits; both schemes) and the Van der Pol variant (Radau) stop IPOPT at its acceptable level
on refined meshes (their singular arcs); Egerstedt's problem did not finish in two minutes; the F-8 aircraft's relaxed minimum time (5.72865,
a local optimum from every guess tried) could not be matched with a value read on its page; the Van der Pol variant's
continuous optimum (1.29443) is not the page's 1.30167235 (n_u = 60), nor are its re-solves on the page's grid
(1.29710 with controls on 60 intervals, 1.29341 by implicit Euler on 6000 steps)."""

from __future__ import annotations

import casadi as ca

from ocpkit import Control, OptimalControlProblem, State

from . import Reference, constants, register

TABLE = "collection_mintoc"


def batch_reactor() -> OptimalControlProblem:
    """Batch reactor A -> B -> C: the temperature profile maximising B at t = 1 (mintOC; Dynopt, Example 6)."""
    c = constants(TABLE, "batch_reactor")
    (a1, b1), (a2, b2) = c["k1"], c["k2"]

    def dynamics(x, u, t):
        k1, k2 = a1 * ca.exp(-b1 / u["T"]), a2 * ca.exp(-b2 / u["T"])
        return [-k1 * x["x1"] ** 2, k1 * x["x1"] ** 2 - k2 * x["x2"]]

    return OptimalControlProblem(
        "mintoc_batch_reactor",
        states=[
            State("x1", 0.0, 1.0, initial=c["x0"][0], guess=(1.0, 0.3)),
            State("x2", 0.0, 1.0, initial=c["x0"][1], guess=(0.0, 0.6)),
        ],
        controls=[Control("T", *c["T"], scale=100.0, guess=350.0, unit="K")],
        dynamics=dynamics,
        tf=c["tf"],
        mayer=lambda x0, xf, t0, tf: -xf["x2"],
        description="Batch reactor, maximum intermediate B (mintOC; Dynopt user's guide, Example 6; PROPT)",
    )


register(
    Reference(
        "mintoc_batch_reactor", "Batch reactor, maximum intermediate",
        "mintOC, Batch reactor (mintoc.de); Dynopt user's guide (Cizniar, Fikar & Latifi 2006), Example 6; PROPT",
        batch_reactor, ("smooth",),
        paper=(TABLE, "mintoc_batch_reactor"), quantity="final_b", value=lambda s: -float(s.objective),
        kind="discretised", mesh="PROPT, 30 collocation points", start=(4, 10),
        statement=r"\max x_2(1)\quad \dot x_1 = -k_1 x_1^2,\ \dot x_2 = k_1 x_1^2 - k_2 x_2,\ "
        r"k_1 = 4000\,e^{-2500/T},\ k_2 = 620000\,e^{-5000/T},\ 298 \le T \le 398,\ x(0) = (1, 0)",
    ),
)  # fmt: skip
