"""A Sphinx extension: the reference collection's gallery, one page per problem of
:mod:`compendium.problems.collection` and an index with a thumbnail per problem, grouped by what each exercises.

When the build starts, ``docs/gallery/`` (not tracked) is written from the registry: each page has the problem's
statement in equations, its source, the code that states it (the function's own source) and the few lines that
solve and draw it, its published values (``data/paper/``) and its results in the published record
(``data/derived/reference_collection*.csv``, notebook 11). The picture on each page is drawn by running those few
lines when the site is built (no picture is committed: it is always the shown code's), two problems at a time; a
picture is kept in ``build/gallery/`` under the hash of everything it depends on (the lines, the library's and the
compendium's sources, the problems' constants), so that a rebuild with nothing changed draws nothing.
"""

from __future__ import annotations

import contextlib
import hashlib
import inspect
import io
import os
import shutil
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PAGES = HERE / "gallery"
IMAGES = HERE / "_generated" / "gallery"
CACHE = ROOT / "build" / "gallery"
#: the tolerance the gallery's lines refine to
TOLERANCE = 1e-6


def _called(make):
    """The named function a one-line ``lambda: f(...)`` calls, else ``make`` itself."""
    if getattr(make, "__name__", "") == "<lambda>" and make.__code__.co_names:
        found = make.__globals__.get(make.__code__.co_names[0])
        if inspect.isfunction(found):
            return found
    return make


def statement_source(ref) -> str:
    """The source of the function that states ``ref`` (the function its one-line lambda calls)."""
    target = _called(ref.make if ref.make is not None else ref.program)
    return inspect.getsource(target).rstrip() + "\n"


def choice(ref, table=None) -> tuple[str, float]:
    """The scheme and tolerance the page's lines solve with: the scheme that gave the collection's converged value
    in the published record (``table``), to 1e-6 or the tightest tolerance it met if looser (a scheme's refinement
    that stalls on a problem would draw a solution it does not trust); Radau at 1e-6 without a record."""
    if table is None or ref.name not in set(table.problem):
        return "Radau", TOLERANCE
    row = table[table.problem == ref.name].iloc[0]
    scheme = row.value_by if row.value_by in ("HLGL", "Radau") else "Radau"
    reached = float(row.value_tolerance) if row.value_tolerance == row.value_tolerance else 1e-3
    return scheme, max(TOLERANCE, reached)


def snippet(ref, table=None) -> str:
    """The lines that solve ``ref`` from its start (:func:`choice`) and draw it."""
    from ocpkit import OptimalControlProblem

    nodes, intervals = ref.start
    name, tol = choice(ref, table)
    scheme = f"HLGL(intervals={intervals})" if name == "HLGL" else f"Radau(nodes={nodes}, intervals={intervals})"
    bound = (
        f"HLGL({{}}, intervals={intervals})" if name == "HLGL" else f"Radau({{}}, nodes={nodes}, intervals={intervals})"
    )
    plain = (
        ref.make is not None
        and ref.program is None
        and ref.guess is None
        and getattr(ref.make, "__name__", "<lambda>") != "<lambda>"
        and not ref.make.__name__.startswith("_")
        and isinstance(ref.make(), OptimalControlProblem)
    )
    if plain:
        return (
            f"from ocpkit import {name}\n"
            f"from {ref.make.__module__} import {ref.make.__name__}\n\n"
            f"solution = {bound.format(ref.make.__name__ + '()')}.solve(mesh_tolerance={tol:g})\n"
            f"value = {_value_expression(ref)}\n"
            f'print(f"{ref.quantity} = {{value:.10g}}")\n'
            "fig = solution.plot()\n"
        )
    guess = "ref.guess()" if ref.guess is not None else "None"
    return (
        f"from ocpkit import {name}\n"
        "from compendium.problems.collection import reference\n\n"
        f'ref = reference("{ref.name}")  # the statement, its program and its guess, as the collection poses them\n'
        f"program = ref.transcribe({scheme})\n"
        f"solution = program.solve({guess}, mesh_tolerance={tol:g}, ipopt_options=ref.ipopt_options or None)\n"
        f'print(f"{ref.quantity} = {{ref.value(solution):.10g}}")\n'
        "fig = solution.plot()\n"
    )


def _value_expression(ref) -> str:
    from compendium.problems.collection import _objective

    return "solution.objective" if ref.value is _objective else f'reference("{ref.name}").value(solution)'


def code_of(ref, table=None) -> str:
    """:func:`snippet`, with the collection's ``reference`` imported where the value needs it."""
    code = snippet(ref, table)
    if "reference(" in code and "import reference" not in code:
        first, rest = code.split("\n", 1)
        code = f"{first}\nfrom compendium.problems.collection import reference\n{rest}"
    return code


def _sources() -> bytes:
    """A digest of everything a page's lines can read besides themselves: the library's and the compendium's sources
    (a statement, its guess and its options live in any of them) and the problems' constants, each file under its
    path, in sorted order (the key must be the same in every build and every process)."""
    h = hashlib.sha256()
    for folder, pattern in ((ROOT / "src", "*.py"), (ROOT / "data" / "problems", "*.toml")):
        for path in sorted(folder.rglob(pattern)):
            h.update(path.relative_to(ROOT).as_posix().encode() + b"\0" + path.read_bytes())
    return h.digest()


def _fingerprint(code: str, sources: bytes) -> str:
    """The key a picture is cached under: its lines and ``sources`` (:func:`_sources`, read once per build)."""
    return hashlib.sha256(sources + code.encode()).hexdigest()[:20]


def draw(code: str, image: str) -> str:
    """Run ``code`` (a fresh namespace, in a scratch folder) and save the figure it assigns to ``fig``; ``""``, or
    the error it raised (as text: an exception may hold what a process pool cannot send back)."""
    try:
        _draw(code, image)
    except Exception as exc:  # noqa: BLE001 - reported by the caller, which fails the build
        return f"{type(exc).__name__}: {exc}"
    return ""


def _draw(code: str, image: str) -> None:
    import warnings

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    here = Path.cwd()
    namespace: dict[str, object] = {"__name__": "__main__"}
    with tempfile.TemporaryDirectory() as folder, contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the page shows the result; the notebook says how each solve ended
        os.chdir(folder)
        try:
            exec(compile(code, f"<gallery {Path(image).stem}>", "exec"), namespace)
            namespace["fig"].savefig(image, dpi=72, metadata={"Software": None})  # type: ignore[attr-defined]
        finally:
            os.chdir(here)
            plt.close("all")


def _table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    head = "| " + " | ".join(title for _, title, _ in columns) + " |"
    rule = "|" + "|".join("---" for _ in columns) + "|"
    body = []
    for row in rows:
        cells = []
        for key, _, fmt in columns:
            value = row.get(key, "")
            try:
                cells.append(format(value, fmt) if fmt and value == value and value != "" else str(value))
            except (TypeError, ValueError):
                cells.append(str(value))
        body.append("| " + " | ".join(c if c != "nan" else "" for c in cells) + " |")
    return "\n".join([head, rule, *body])


def _records():
    import pandas as pd

    derived = ROOT / "data" / "derived"
    problems = derived / "reference_collection.csv"
    meshes = derived / "reference_collection_meshes.csv"
    table = pd.read_csv(problems) if problems.is_file() else None
    refinement = pd.read_csv(meshes) if meshes.is_file() else None
    return table, refinement


def page(ref, table, refinement) -> str:
    from compendium.problems.collection import EXERCISES

    published = ref.published_rows()
    lines = [
        f"# {ref.title}",
        "",
        f"**Source:** {ref.source}. **Exercises:** "
        + ", ".join(f"[{EXERCISES[t]}](index.md#{t})" for t in ref.exercises)
        + f". **Name in the collection:** `{ref.name}`.",
        "",
    ]
    if ref.statement:
        lines += ["$$", ref.statement, "$$", ""]
    lines += ["## The code", "", "The statement:", "", "```python", statement_source(ref).rstrip(), "```", ""]
    lines += ["Solved and drawn (these lines draw the picture below when the site is built):", ""]
    lines += [
        "```python",
        code_of(ref, table).rstrip(),
        "```",
        "",
        f"![{ref.title}: solution.plot()](../_generated/gallery/{ref.name}.png)",
        "",
    ]
    lines += ["## Published values", ""]
    if not published.empty:
        rows = published.to_dict("records")
        cols = [
            (c, c, ".10g" if c == "value" else "")
            for c in published.columns
            if c in ("quantity", "value", "digits", "kind", "mesh", "source")
        ]
        lines += [_table(rows, cols), ""]
    if ref.closed_form is not None:
        lines += [f"Closed form: {ref.closed_form():.12g}.", ""]
    if ref.why:
        lines += [f"The two schemes are expected to agree to {ref.agreement:g}: {ref.why}.", ""]
    if ref.differs:
        lines += [f"Why the converged value differs from the published one: {ref.differs}.", ""]
    lines += ["## Results (notebook 11, the published record)", ""]
    if table is not None and ref.name in set(table.problem):
        row = table[table.problem == ref.name].iloc[0].to_dict()
        lines += [
            _table([row], [("value", "converged value", ".10g"), ("value_by", "by", ""), ("value_tolerance", "to", ".0e"),
                           ("hlgl", "HLGL", ".10g"), ("radau", "Radau", ".10g"), ("published", "published", ".10g"),
                           ("published_verdict", "against it", ""), ("indirect", "indirect", ""),
                           ("defaults", "at defaults", "")]),
            "",
        ]  # fmt: skip
    else:
        lines += [
            "Not yet in the published record: `make reproduce NOTEBOOKS=notebooks/11_reference_collection.ipynb`.",
            "",
        ]
    if refinement is not None and ref.name in set(refinement.problem):
        mine = refinement[refinement.problem == ref.name].to_dict("records")
        lines += [
            "Refinement to each tolerance from the same start (`data/derived/reference_collection_meshes.csv`; every "
            "mesh with its breakpoints in `reference_collection_history.csv`):",
            "",
            _table(mine, [("scheme", "scheme", ""), ("tolerance", "tolerance", ".0e"), ("outcome", "outcome", ""),
                          ("meshes", "meshes", ".0f"), ("intervals", "intervals", ".0f"), ("points", "points", ".0f"),
                          ("ipopt_iterations", "IPOPT iterations", ".0f"), ("estimate", "estimate", ".1e"),
                          ("true_error", "true error", ".1e"), ("time_s", "time (s)", ".2f")]),
            "",
        ]  # fmt: skip
    return "\n".join(lines)


def index(refs) -> str:
    from compendium.problems.collection import EXERCISES

    lines = [
        "# Gallery: the reference collection",
        "",
        f"{len(refs)} published problems, each stated once with its source (`compendium.problems.collection`), its "
        "constants in `data/problems/` and its published values in `data/paper/`; notebook 11 computes their "
        "converged values, their refinement tables and what a solve at defaults gives "
        "([the notebook](../_notebooks/11_reference_collection.ipynb)). Each page shows the statement, its code, "
        "the result against the reference and its picture, drawn by the code on the page.",
        "",
        "```{toctree}",
        ":hidden:",
        "",
        *[ref.name for ref in refs],
        "```",
        "",
    ]
    for tag, words in EXERCISES.items():
        mine = [r for r in refs if tag in r.exercises]
        if not mine:
            continue
        lines += [f"({tag})=", f"## {words[0].upper()}{words[1:]}", "", '<div class="gallery-grid">', ""]
        for r in mine:
            lines += [
                f'<a class="gallery-item" href="{r.name}.html"><img src="../_images/{r.name}.png" alt="{r.title}">'
                f"<span>{r.title}</span></a>",
            ]
        lines += ["", "</div>", ""]
    return "\n".join(lines)


def write_gallery(draw_images: bool = True) -> list[Path]:
    """Write the pages (and, with ``draw_images``, the pictures); the pictures' paths."""
    from compendium.problems.collection import references

    refs = references()
    table, refinement = _records()
    if PAGES.exists():
        shutil.rmtree(PAGES)
    PAGES.mkdir(parents=True)
    IMAGES.mkdir(parents=True, exist_ok=True)
    CACHE.mkdir(parents=True, exist_ok=True)
    (PAGES / "index.md").write_text(index(refs))
    todo, sources = [], _sources()
    for ref in refs:
        (PAGES / f"{ref.name}.md").write_text(page(ref, table, refinement))
        code = code_of(ref, table)
        cached = CACHE / f"{ref.name}-{_fingerprint(code, sources)}.png"
        if not cached.is_file():
            todo.append((code, str(cached)))
    if draw_images and todo:
        with ProcessPoolExecutor(max_workers=2) as pool:
            errors = [f"{Path(image).stem}: {e}" for (_, image), e in zip(todo, pool.map(draw, *zip(*todo))) if e]
        if errors:
            raise RuntimeError("the gallery's code failed on " + "; ".join(errors))
    images = []
    for ref in refs:
        code = code_of(ref, table)
        cached = CACHE / f"{ref.name}-{_fingerprint(code, sources)}.png"
        if cached.is_file():
            shutil.copyfile(cached, IMAGES / f"{ref.name}.png")
            images.append(IMAGES / f"{ref.name}.png")
    return images


def _write(app) -> None:
    write_gallery()


def setup(app):
    app.connect("builder-inited", _write)
    return {"parallel_read_safe": True}
