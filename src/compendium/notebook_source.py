"""What a compendium notebook says about itself, read from its file: its parameters, published parameters and code.

The readers every other layer shares, with nothing below them but :mod:`compendium.paths`: the cell tagged
``parameters`` (:func:`parameters_cell`) and its defaults (:func:`notebook_parameters`, as Python values
:func:`literal_parameters`), the parameters ``notebooks/published.toml`` sets for a notebook's published run
(:func:`published_overrides`, :func:`published_parameters`), the digests of its code cells (:func:`code_digest`,
:func:`notebook_code`), where an executed notebook says its run wrote (:func:`written_to`), and its outputs without
the views of live widgets (:func:`static_views`). :mod:`compendium.provenance`, :mod:`compendium.outputs`,
:mod:`compendium.report` and :mod:`compendium.notebooks` build on them.
"""

from __future__ import annotations

import ast
import hashlib
import re
from pathlib import Path

from . import paths

# -- the parameters cell ---------------------------------------------------------------------------------------------


def parameters_cell(path: str | Path):
    """The single cell tagged ``parameters`` of a notebook."""
    import nbformat

    nb = nbformat.read(str(path), as_version=4)
    cells = [c for c in nb.cells if "parameters" in c.metadata.get("tags", [])]
    if len(cells) != 1:
        raise ValueError(f"{Path(path).name} must have exactly one cell tagged 'parameters', found {len(cells)}")
    return cells[0]


def notebook_parameters(path: str | Path) -> dict:
    """Parameters declared in the notebook's ``parameters`` cell: name -> default (source text).

    Every assignment in the cell must be one papermill can parse (it silently
    skips, for instance, a line whose comment contains ``=``, or one annotated
    ``float | None``); otherwise the parameter could not be set from the command
    line, and this raises.
    """
    import papermill as pm

    cell = parameters_cell(path)
    assigned = [
        t.id
        for node in ast.parse(cell.source).body
        if isinstance(node, (ast.Assign, ast.AnnAssign))
        for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
        if isinstance(t, ast.Name)
    ]
    params = pm.inspect_notebook(str(path))
    missed = [name for name in assigned if name not in params]
    if missed:
        raise ValueError(f"papermill cannot parse the parameter line(s) of {missed} in {Path(path).name}")
    return {name: spec["default"] for name, spec in params.items()}


def literal_parameters(path: str | Path) -> dict:
    """The defaults of :func:`notebook_parameters` as Python values (every default must be a literal)."""
    out = {}
    for name, text in notebook_parameters(path).items():
        try:
            out[name] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            raise ValueError(f"the default of {name!r} in {Path(path).name} is not a Python literal: {text}") from None
    return out


def check_parameters(path: str | Path, parameters: dict) -> None:
    """Raise ``ValueError`` naming any parameter the notebook does not declare, or whose value is not of the
    parameter's type (:func:`parameter_types`): the notebook, the parameter, the value given, the type expected and
    an example of ``-p NAME VALUE``, each wrong parameter on its own line."""
    known = notebook_parameters(path)
    unknown = sorted(set(parameters) - set(known))
    if unknown:
        raise ValueError(f"unknown parameter(s) {unknown} for {Path(path).name}; its parameters are {sorted(known)}")
    types, defaults = parameter_types(path), literal_parameters(path)
    wrong = [
        _wrong_type(Path(path).name, name, value, types[name], defaults[name])
        for name, value in parameters.items()
        if types[name] and not _admits(types[name], value)
    ]
    if wrong:
        raise ValueError("\n".join(wrong))


#: the types a parameter may declare, by the name its annotation or default gives them
_TYPES: dict[str, type] = {t.__name__: t for t in (float, int, bool, str, list, dict, tuple)}
#: the example value of ``-p NAME VALUE`` for a type whose parameter has no default of it
_EXAMPLES = {
    float: "2.5",
    int: "10",
    bool: "True",
    str: "word",
    list: "[1.0, 2.0]",
    dict: "{'key': 1.0}",
    tuple: "(1, 2)",
}


def parameter_types(path: str | Path) -> dict[str, tuple[type | None, ...]]:
    """The types each parameter of the notebook admits (``None`` for the value ``None``): the type its parameters
    cell names, as an annotation (``thrust_to_weight: float = None``) or a type comment (``thrusts = [5.0]  #
    type: Optional[list] ...``): ``float``, ``int``, ``bool``, ``str``, ``list``, ``dict`` or ``tuple``, maybe with
    ``[...]`` after it, or ``Optional[...]`` of one; else the type of its default. A default of ``None`` admits
    ``None`` too; ``()`` where nothing names a type (a default of ``None`` without one: any value). An ``int`` is
    admitted for a ``float`` (:func:`check_parameters`). papermill parses no ``X | None``: write ``Optional[X]``."""
    import papermill as pm

    defaults = literal_parameters(path)
    out: dict[str, tuple[type | None, ...]] = {}
    for name, spec in pm.inspect_notebook(str(path)).items():
        annotation = spec.get("inferred_type_name") or "None"
        if annotation != "None":
            out[name] = _annotated(Path(path).name, name, annotation)
            if defaults[name] is None and None not in out[name]:
                out[name] += (None,)
        elif defaults[name] is None:
            out[name] = ()
        else:
            out[name] = (type(defaults[name]),)
    return out


def _annotated(notebook: str, name: str, annotation: str) -> tuple[type | None, ...]:
    text, optional = annotation.strip(), False
    inner = re.fullmatch(r"Optional\[(.*)\]", text)
    if inner:
        text, optional = inner.group(1).strip(), True
    base = _TYPES.get(re.sub(r"\[.*\]$", "", text).strip().lower())
    if base is None:
        raise ValueError(
            f"the annotation {annotation!r} of the parameter {name!r} in {notebook} is none of "
            f"{sorted(_TYPES)} (maybe with [...] after it) or Optional[...] of one: write one of those"
        )
    return (base, None) if optional else (base,)


def _admits(types: tuple[type | None, ...], value) -> bool:
    if value is None:
        return None in types
    if isinstance(value, bool):  # a bool is an int to isinstance; neither a number nor a count is True
        return bool in types
    return any(t is not None and (isinstance(value, t) or (t is float and isinstance(value, int))) for t in types)


def _wrong_type(notebook: str, name: str, value, types: tuple[type | None, ...], default) -> str:
    import shlex

    expected = " or ".join("None" if t is None else t.__name__ for t in types)
    kind = "None" if value is None else type(value).__name__
    shown = default if isinstance(default, str) else repr(default)
    usable = default is not None and len(shown) <= 40 and not (isinstance(default, (list, tuple, dict)) and not default)
    example = shown if usable else _EXAMPLES[next(t for t in types if t)]
    # a Python literal with quotes in it reads best in double quotes (shlex.quote would splice '"'"' into it)
    quoted = f'"{example}"' if "'" in example and not any(c in example for c in '"$`\\!') else shlex.quote(example)
    return (
        f"{notebook}: the parameter {name!r} takes {_a(expected)}, but the value given is {value!r} ({_a(kind)}): "
        f"give {_a(expected)}, e.g. -p {name} {quoted}"
    )


def _a(noun: str) -> str:
    return noun if noun == "None" else f"{'an' if noun[0] in 'aeiou' else 'a'} {noun}"


def default_parameters(notebook: str) -> dict:
    """The defaults of the parameters cell of ``notebooks/<notebook>.ipynb``, as Python values."""
    return literal_parameters(paths.notebooks_dir() / f"{notebook}.ipynb")


# -- the published parameters ----------------------------------------------------------------------------------------


def published_overrides(path: str | Path) -> dict:
    """The parameters ``notebooks/published.toml`` sets for the notebook's published run (values as Python)."""
    import tomllib

    table = tomllib.loads((Path(path).parent / "published.toml").read_text()).get(Path(path).stem, {})
    return {k: ast.literal_eval(v) for k, v in table.items()}


def none_meanings(path: str | Path) -> dict[str, str]:
    """What ``None`` stands for, for each parameter whose comment in the parameters cell says it (``# ...; None: the
    paper's (data/problems/...)`` gives ``"the paper's"``: up to a parenthesis, a semicolon or a comma)."""
    import papermill as pm

    out = {}
    for name, spec in pm.inspect_notebook(str(path)).items():
        said = re.search(r"\bNone:\s*([^;(,]*[^;(,\s])", spec.get("help") or "")
        if said:
            out[name] = said.group(1)
    return out


def published_parameters(notebook: str) -> dict:
    """The parameters of the notebook's published run: its parameters cell, updated by ``notebooks/published.toml``."""
    path = paths.notebooks_dir() / f"{notebook}.ipynb"
    params, overrides = default_parameters(notebook), published_overrides(path)
    unknown = sorted(set(overrides) - set(params))
    if unknown:
        raise ValueError(f"notebooks/published.toml names unknown parameter(s) {unknown} of {notebook}")
    return params | overrides


# -- code cells ------------------------------------------------------------------------------------------------------


def code_digest(source: str) -> str:
    """The digest of one code cell's source (trailing white space aside)."""
    return hashlib.sha256(source.rstrip().encode()).hexdigest()[:16]


def notebook_code(path: Path) -> list[str]:
    """Digests of a notebook file's code cells, in order."""
    import nbformat

    nb = nbformat.read(str(path), as_version=4)
    return [
        code_digest(c.source)
        for c in nb.cells
        if c.cell_type == "code" and "injected-parameters" not in c.metadata.get("tags", [])
    ]


# -- outputs ---------------------------------------------------------------------------------------------------------

# the first output line of a run: the words of compendium.outputs.Outputs.describe
_WRITES_TO = re.compile(r"^This run writes its figures and tables to (.+?)/ when it completes")


def written_to(executed: str | Path) -> Path | None:
    """The folder an executed notebook's run wrote its figures and tables to (its first output line says)."""
    import nbformat

    nb = nbformat.read(str(executed), as_version=4)
    for cell in nb.cells:
        for output in cell.get("outputs", []) if cell.cell_type == "code" else []:
            m = _WRITES_TO.match(output.get("text", ""))
            if m:
                where = Path(m.group(1))
                return where if where.is_absolute() else paths.repo_root() / where
    return None


#: the output of a live widget: its model lives in the kernel that made it
WIDGET_VIEW = "application/vnd.jupyter.widget-view+json"


def static_views(outputs: list) -> list:
    """``outputs`` without the views of live widgets (``compendium.explorer``) where a static picture comes with
    them: stored without its kernel, a widget view renders nothing (nbconvert, nbviewer and GitHub pick it first
    and show a blank) and its model id changes with every run; the picture is what a reader without the kernel
    sees."""
    for out in outputs:
        data = out.get("data") if out.get("output_type") in ("display_data", "execute_result") else None
        if data and WIDGET_VIEW in data and len(set(data) - {WIDGET_VIEW, "text/plain"}) > 0:
            del data[WIDGET_VIEW]
    return outputs
