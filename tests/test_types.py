"""The library's type hints (issue 27): mypy finds nothing in ``src/ocpkit`` under the configuration of
``pyproject.toml`` (``[tool.mypy]``), and every public function, class and method of ocpkit says what it takes and
what it returns."""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SOURCE = REPO / "src" / "ocpkit"

#: the modules a user imports from: what each exports (``__all__``), or else what it defines without a leading
#: underscore
PUBLIC_MODULES = [
    "ocpkit",
    "ocpkit.accuracy",
    "ocpkit.analysis",
    "ocpkit.errors",
    "ocpkit.flight",
    "ocpkit.hamiltonian_form",
    "ocpkit.indirect",
    "ocpkit.interpolation",
    "ocpkit.monotone",
    "ocpkit.names",
    "ocpkit.nlp",
    "ocpkit.nodes",
    "ocpkit.outcome",
    "ocpkit.problem",
    "ocpkit.program",
    "ocpkit.program.assembly",
    "ocpkit.program.layout",
    "ocpkit.program.loop",
    "ocpkit.program.program",
    "ocpkit.program.scheme",
    "ocpkit.program.solve",
    "ocpkit.statement",
    "ocpkit.statement.bounds",
    "ocpkit.statement.constraints",
    "ocpkit.statement.functions",
    "ocpkit.statement.guess",
    "ocpkit.statement.phases",
    "ocpkit.statement.problem",
    "ocpkit.statement.symbols",
    "ocpkit.statement.times",
    "ocpkit.statement.variables",
    "ocpkit.regularisation",
    "ocpkit.scaling",
    "ocpkit.shooting",
    "ocpkit.shooting.arcs",
    "ocpkit.shooting.compiled",
    "ocpkit.shooting.continuation",
    "ocpkit.shooting.hamiltonian",
    "ocpkit.shooting.multiple",
    "ocpkit.shooting.result",
    "ocpkit.shooting.shooting",
    "ocpkit.shooting.strategies",
    "ocpkit.shooting.trajectory",
    "ocpkit.solution",
    "ocpkit.structure",
    "ocpkit.trajectory",
    "ocpkit.transcription",
    "ocpkit.transcription.base",
    "ocpkit.transcription.hlgl",
    "ocpkit.transcription.loop",
    "ocpkit.transcription.mesh",
    "ocpkit.transcription.multirate",
    "ocpkit.transcription.phases",
    "ocpkit.transcription.radau",
    "ocpkit.transcription.registry",
    "ocpkit.transcription.scheme",
    "ocpkit.transcription.session",
]

#: the methods checked besides the public ones (a dataclass's generated __eq__ and __repr__ are not ocpkit's)
CHECKED_DUNDERS = ("__init__", "__call__", "__getitem__")


def test_mypy_finds_nothing():
    """``python -m mypy`` (its files and options from pyproject.toml) checks src/ocpkit without a finding."""
    if importlib.util.find_spec("mypy") is None:
        pytest.skip(
            "mypy is not installed in this environment, so the type check cannot run here: install the mypy "
            "pinned in environment.txt (`make setup`) and run this test or `python -m mypy`"
        )
    proc = subprocess.run([sys.executable, "-m", "mypy"], cwd=REPO, capture_output=True, text=True)
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"mypy's findings:\n{output[-6000:]}"
    assert re.search(r"^Success: no issues found in \d+ source files?$", proc.stdout, re.M), output


def test_the_mypy_configuration_checks_everything():
    """No blanket escape: every function annotated and every body checked; only untyped third-party modules are let
    through (per module, by name), never ocpkit's own errors."""
    config = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["mypy"]
    assert config["files"] == ["src/ocpkit"]
    assert config["python_version"] == "3.11"
    for option in ("disallow_untyped_defs", "disallow_incomplete_defs", "check_untyped_defs", "warn_unused_ignores"):
        assert config.get(option) is True, option
    for option in ("ignore_errors", "ignore_missing_imports", "follow_imports", "disable_error_code"):
        assert option not in config, f"[tool.mypy] sets {option}"
    for override in config.get("overrides", []):
        modules = override["module"] if isinstance(override["module"], list) else [override["module"]]
        assert set(override) == {"module", "ignore_missing_imports"}, override
        assert all(m.split(".")[0] in {"scipy", "pandas"} for m in modules), modules


def test_every_type_ignore_names_its_error_and_why():
    """A ``# type: ignore`` silences one error code where the code is right and mypy cannot see it, and says why."""
    bare, unexplained = [], []
    for path in sorted(SOURCE.rglob("*.py")):
        for number, line in enumerate(path.read_text().splitlines(), start=1):
            if "type: ignore" not in line:
                continue
            where = f"{path.relative_to(REPO)}:{number}"
            match = re.search(r"type: ignore\[[a-z-]+(, *[a-z-]+)*\](.*)$", line)
            if match is None:
                bare.append(where)
            elif not match.group(2).strip().startswith("#"):
                above = path.read_text().splitlines()[number - 2].strip()
                if not above.startswith("#"):
                    unexplained.append(where)
    assert not bare, f"type: ignore without an error code at {bare}"
    assert not unexplained, f"type: ignore without a reason at {unexplained}"


def _public_names(module) -> list[str]:
    if hasattr(module, "__all__"):
        return list(module.__all__)
    return [
        name
        for name, obj in vars(module).items()
        if not name.startswith("_")
        and (inspect.isfunction(obj) or inspect.isclass(obj))
        and obj.__module__ == module.__name__
    ]


def _missing(function, where: str) -> list[str]:
    """The parameters (and ``return``) of ``function`` without an annotation, each named with ``where``."""
    signature = inspect.signature(function)
    names = list(signature.parameters)
    skip = names[:1] if names and names[0] in ("self", "cls") else []
    out = [
        f"{where}({p.name})"
        for p in signature.parameters.values()
        if p.name not in skip and p.annotation is inspect.Parameter.empty
    ]
    if signature.return_annotation is inspect.Signature.empty:
        out.append(f"{where} -> ?")
    return out


def _own_methods(cls) -> list[tuple[str, object]]:
    """The functions a class defines itself (public ones and :data:`CHECKED_DUNDERS`), properties by their getter."""
    out = []
    for name, member in vars(cls).items():
        if name.startswith("_") and name not in CHECKED_DUNDERS:
            continue
        if isinstance(member, (staticmethod, classmethod)):
            member = member.__func__
        elif isinstance(member, property):
            member = member.fget
        elif hasattr(member, "func") and type(member).__name__ == "cached_property":
            member = member.func
        if inspect.isfunction(member) and member.__module__.startswith("ocpkit"):
            out.append((name, member))
    return out


def _public_callables() -> dict[str, object]:
    found: dict[str, object] = {}
    for module_name in PUBLIC_MODULES:
        module = importlib.import_module(module_name)
        for name in _public_names(module):
            obj = getattr(module, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                found.setdefault(f"{obj.__module__}.{obj.__qualname__}", obj)
    return found


def test_the_public_callables_are_found():
    """The check below sees what a user calls (a change of how the names are collected would skip them silently)."""
    found = _public_callables()
    for name in (
        "ocpkit.statement.problem.OptimalControlProblem",
        "ocpkit.transcription.hlgl.HLGL",
        "ocpkit.transcription.radau.Radau",
        "ocpkit.transcription.phases.MultiPhase",
        "ocpkit.program.program.Program",
        "ocpkit.statement.phases.MultiPhaseProblem",
        "ocpkit.solution.Solution",
        "ocpkit.shooting.shooting.Shooting",
        "ocpkit.shooting.hamiltonian.control_law",
        "ocpkit.shooting.continuation.follow",
        "ocpkit.indirect.to_extremal",
        "ocpkit.structure.control_structure",
        "ocpkit.accuracy.interval_errors",
        "ocpkit.scaling.autoscale",
        "ocpkit.regularisation.penalise_control",
        "ocpkit.analysis.convergence_order",
    ):
        assert name in found, name
    methods = {name for cls in found.values() if inspect.isclass(cls) for name, _ in _own_methods(cls)}
    assert {"solve", "loop", "sample", "value", "reintegrate", "state", "control", "__init__"} <= methods


def test_every_public_callable_is_annotated():
    """Every parameter and the return of each public function, class constructor and public method carries a type
    hint (the API reference shows them: Sphinx's ``autodoc_typehints = "description"``)."""
    missing = []
    for where, obj in sorted(_public_callables().items()):
        if inspect.isfunction(obj):
            missing += _missing(obj, where)
            continue
        for name, method in _own_methods(obj):
            missing += _missing(method, f"{where}.{name}")
    assert not missing, f"{len(missing)} annotations missing:\n" + "\n".join(missing)


# -- what the type check found -------------------------------------------------------------------------------------


def test_a_guess_of_none_is_the_variables_own():
    """``Guess(states={"x": None})``: a :data:`~ocpkit.problem.GuessSpec` of None is derived from the variable (its
    own guess, else its bounds or boundary conditions), as the names left out are; it was called as a function
    (``'NoneType' object is not callable``), which mypy found."""
    import numpy as np

    import ocpkit as ok

    problem = ok.OptimalControlProblem(
        "guess",
        [ok.State("x", initial=0.0, final=1.0), ok.State("y", guess=0.5)],
        [ok.Control("u", -1.0, 3.0)],
        lambda x, u, t: [u, x[0]],
        tf=2.0,
        lagrange=lambda x, u, t: u**2,
    )
    t = np.linspace(0.0, 2.0, 5)
    _, xs, us = ok.Guess(states={"x": None, "y": None}, controls={"u": None}).functions(problem)
    _, xs_default, us_default = ok.Guess().functions(problem)
    np.testing.assert_array_equal(xs(t), xs_default(t))
    np.testing.assert_array_equal(us(t), us_default(t))
    np.testing.assert_allclose(xs(t)[:, 0], t / 2.0)
    np.testing.assert_allclose(xs(t)[:, 1], 0.5)
    np.testing.assert_allclose(us(t)[:, 0], 1.0)
