"""Function evaluations and build of the NLP against CasADi's floor: interpreted, compiled and SX-expanded blocks.

    python benchmarks/bench_evaluations.py [--segments 1000 5000] [--repeat 20]

For the HLGL lunar ascent and flat-moon ascent at each ``--segments``, one NLP three ways:

- ``interpreted``: ocpkit's blocks mapped by CasADi's SX virtual machine (``compile=False``);
- ``compiled``: the Jacobian and Hessian blocks compiled to C (``compile=True``, the library from the cache);
- ``expanded``: CasADi's reference, the same ``jac_g`` and ``hess_lag`` expanded into one SX function each
  (what ``nlpsol(..., {"expand": True})`` evaluates).

Per-evaluation wall time (median of ``--repeat`` calls at the default start, with random multipliers) of
``jac_g`` and ``hess_lag``; issue 26's goal: the compiled blocks within 1.2x of the expanded functions. Every way
must give the same values (the interpreted and compiled ones to the last bit). ``build_s`` is the NLP's build and
its IPOPT instance's (best of three; issue 26's goal at 5000 segments: under 0.3 s); ``first_compile_s`` the
compiled build in an empty cache (once per machine). Writes ``build/bench/evaluations.csv``.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time

import casadi as ca
import numpy as np
from _harness import goal, parser, report

from ocpkit import HLGL

from compendium.paths import build_dir
from compendium.problems import flat_moon_ascent, lunar_ascent

PROBLEMS = {"lunar ascent": lunar_ascent, "flat moon": flat_moon_ascent}


def per_call(fun: ca.Function, args: list, repeat: int) -> float:
    fun.call(args)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fun.call(args)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def built(make, compile, repeat: int = 3):
    """The transcription with its NLP and IPOPT instance built, and the best build time."""
    best, tr = float("inf"), None
    for _ in range(repeat):
        tr = make()
        tr.compile = compile
        t0 = time.perf_counter()
        tr.solver()
        best = min(best, time.perf_counter() - t0)
    return tr, best


def values(fun, args) -> np.ndarray:
    return np.concatenate([np.array(ca.DM(out).nonzeros()) for out in fun.call(args)])


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "evaluations.csv"))
    ap.add_argument("--segments", type=int, nargs="+", default=[1000, 5000])
    ap.set_defaults(repeat=20)
    args = ap.parse_args()
    rows = []
    for label, problem in PROBLEMS.items():
        for n in args.segments:

            def make(n=n, problem=problem):
                return HLGL(problem(), n)

            with tempfile.TemporaryDirectory() as cache:  # a first compilation, in an empty cache
                previous = os.environ.get("OCPKIT_CACHE_DIR")
                os.environ["OCPKIT_CACHE_DIR"] = cache
                try:
                    first_compile = built(make, True, repeat=1)[1]
                finally:
                    if previous is None:
                        del os.environ["OCPKIT_CACHE_DIR"]
                    else:
                        os.environ["OCPKIT_CACHE_DIR"] = previous
            interpreted, build_interpreted = built(make, False)
            compiled, build_compiled = built(make, True)
            nlp = compiled.nlp
            rng = np.random.default_rng(0)
            w = ca.DM(compiled.initial_point())
            jac_args = [w, ca.DM(0, 1)]
            hess_args = [w, ca.DM(0, 1), ca.DM(1.0), ca.DM(rng.normal(size=nlp.n_constraints))]
            t0 = time.perf_counter()
            plain = interpreted.nlp  # (the compiled NLP's functions call the library: no SX to expand)
            expanded = {"jac_g": plain.jac_g.expand(), "hess_lag": plain.hess_lag.expand()}
            expand_s = time.perf_counter() - t0
            row = {"problem": label, "segments": n, "variables": nlp.n_variables}
            for name, fargs in (("jac_g", jac_args), ("hess_lag", hess_args)):
                ways = {"interpreted": getattr(interpreted.nlp, name), "compiled": getattr(nlp, name)}
                ways["expanded"] = expanded[name]
                reference = values(ways["interpreted"], fargs)
                if not np.array_equal(values(ways["compiled"], fargs), reference):
                    raise SystemExit(f"{label} {n}: compiled {name} differs from the interpreted one")
                if not np.allclose(values(ways["expanded"], fargs), reference, rtol=1e-12, atol=1e-12):
                    raise SystemExit(f"{label} {n}: expanded {name} differs from the interpreted one")
                for way, fun in ways.items():
                    row[f"{name}_{way}_ms"] = 1e3 * per_call(fun, fargs, args.repeat)
                ratio = row[f"{name}_compiled_ms"] / row[f"{name}_expanded_ms"]
                row[f"{name}_ratio"] = ratio
                row[f"{name}_goal"] = goal(ratio, 1.2)
            row.update(
                build_interpreted_s=build_interpreted,
                build_compiled_s=build_compiled,
                build_goal=goal(build_compiled, 0.3, " s") if n == 5000 else "",
                first_compile_s=first_compile,
                expand_s=expand_s,
            )
            rows.append(row)
            print(
                f"{label} {n}: jac_g {row['jac_g_compiled_ms']:.2f} ms (expanded {row['jac_g_expanded_ms']:.2f}), "
                f"hess_lag {row['hess_lag_compiled_ms']:.2f} ms (expanded {row['hess_lag_expanded_ms']:.2f}), "
                f"build {build_compiled:.3f} s",
                flush=True,
            )
    cols = ["problem", "segments"]
    cols += [f"{f}_{w}_ms" for f in ("jac_g", "hess_lag") for w in ("interpreted", "compiled", "expanded")]
    cols += ["jac_g_ratio", "jac_g_goal", "hess_lag_ratio", "hess_lag_goal", "build_interpreted_s"]
    cols += ["build_compiled_s", "build_goal", "first_compile_s"]
    fmt = {c: ".2f" for c in cols if c.endswith("_ms") or c.endswith("_ratio")}
    report(rows, cols, args.output, f"NLP evaluations per call (median of {args.repeat}) and build", fmt)


if __name__ == "__main__":
    main()
