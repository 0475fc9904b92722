"""The README's library example runs as printed, from a folder outside the repository."""

import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _section(title: str) -> str:
    text = (REPO / "README.md").read_text()
    start = text.index(f"## {title}")
    end = text.find("\n## ", start + 1)
    return text[start : end if end > 0 else None]


def _same_print(printed: str, shown: str) -> list[str]:
    """Differences of what an example printed from what the README shows, by the contract's classes: the words
    exactly, a re-integration error by its magnitude (rounding noise below 1e-12), every other number converged."""
    from compendium.contract import Converged, Error, text_differences

    out = []
    a, b = printed.strip().splitlines(), shown.strip().splitlines()
    if len(a) != len(b):
        return [f"{len(a)} lines printed, {len(b)} shown"]
    for x, y in zip(a, b):
        (x0, _, x1), (y0, _, y1) = x.partition("re-integration error"), y.partition("re-integration error")
        out += text_differences(" ".join(x0.split()), " ".join(y0.split()), Converged())
        out += text_differences(x1.strip(), y1.strip(), Error(floor=1e-12))
    return out


def test_library_example_runs_and_prints_what_the_readme_shows(tmp_path):
    section = _section("The library on its own")
    code, printed = re.findall(r"```(?:python)?\n(.*?)```", section, flags=re.S)[:2]
    assert "import ocpkit" in code or "from ocpkit" in code
    assert "compendium" not in code, "the example uses the library alone"
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert _same_print(proc.stdout, printed) == []


def test_the_printed_example_is_compared_by_class_not_digit_for_digit():
    shown = "ShootingTrajectory J = 0.23066243, re-integration error 1.2e-15"
    assert _same_print("ShootingTrajectory J = 0.23066243, re-integration error 1.1e-15", shown) == []
    assert _same_print("ShootingTrajectory J = 0.23066243, re-integration error 8.0e-16", shown) == []
    assert _same_print("ShootingTrajectory J = 0.23067243, re-integration error 1.2e-15", shown)  # 4e-5 relative
    assert _same_print("ShootingTrajectory J = 0.23066243, re-integration error 1.2e-05", shown)


def test_library_example_matches_the_exact_cost(tmp_path):
    """J = 3/8 - sqrt(3)/12: the saturated-linear control u = 0.5 sat((t - 1.5) / sigma), sigma^2 = 3/4."""
    code = re.findall(r"```python\n(.*?)```", _section("The library on its own"), flags=re.S)[0]
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102
    exact = 3 / 8 - 3**0.5 / 12
    assert abs(namespace["indirect"].objective - exact) < 1e-9
    for name in ("hlgl", "radau"):
        assert abs(namespace[name].objective - exact) < 1e-5, name


def _subsection(title: str) -> str:
    text = (REPO / "README.md").read_text()
    start = text.index(f"### {title}")
    ends = [i for i in (text.find("\n### ", start + 1), text.find("\n## ", start + 1)) if i > 0]
    return text[start : min(ends) if ends else None]


def test_other_parameters_examples_run_verbatim_on_a_fresh_clone(tmp_path):
    """Both commands, as printed, in a fresh clone: they work, and the published record stays as it was."""
    import json
    import os

    commands = re.findall(r"```sh\n(.*?)```", _subsection("One notebook with other parameters"), flags=re.S)
    assert len(commands) == 2 and all("segments 40" in c for c in commands)
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    (clone / ".venv").symlink_to(REPO / ".venv")  # what `make setup` would build, shared
    env = {k: v for k, v in os.environ.items() if k != "OCPKIT_OUTPUT_DIR"} | {"OCPKIT_ROOT": str(clone)}
    for command in commands:
        proc = subprocess.run(command, shell=True, cwd=clone, env=env, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, f"{command}\n{proc.stderr[-3000:]}"
    run = clone / "build" / "runs" / "01_lunar_ascent" / "segments-40"
    assert (run / "01_lunar_ascent.ipynb").is_file(), "the runner's executed notebook, beside its figures"
    assert (clone / "build" / "lunar_40.ipynb").is_file()
    record = json.loads((run / "data" / "derived" / "runs" / "01_lunar_ascent.json").read_text())
    assert record["parameters"]["segments"] == 40 and record["published_parameters"] is False
    assert json.loads((run / "data" / "derived" / "lunar_ascent_summary.json").read_text())["segments"] == 40
    assert (run / "figures" / "figure6_theta.png").is_file()
    status = subprocess.run(
        ["git", "status", "--porcelain", "--", "figures", "data", "notebooks", "src"],
        cwd=clone,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert status == "", f"the published record changed:\n{status}"


def test_sources_are_cited_by_reference_not_by_a_path_outside_the_repository():
    """A reader of the compendium has no ../shared/seeds: the README and the notebooks cite authors and titles."""
    texts = {"README.md": (REPO / "README.md").read_text()}
    texts |= {p.name: p.read_text() for p in sorted((REPO / "notebooks").glob("*.ipynb"))}
    for name, text in texts.items():
        assert "shared/seeds" not in text and "seeds/00" not in text, name
    readme = texts["README.md"]
    for cited in ("Desai", "Conway", "Martinon", "Gergaud", "Fuel optimal entry trajectory with Radau", "Herman"):
        assert cited in readme, cited


def test_constraints_and_phases_example_runs_and_prints_what_the_readme_shows(tmp_path):
    """The path-constraint and two-phase example, as printed: J = 4 (Bryson-Denham) and the gravity a bounce's
    timing asks for, 2 (1.9 / 0.8)^2 (phases without a cost, a shared parameter, a linkage constraint)."""
    code, printed = re.findall(
        r"```(?:python)?\n(.*?)```", _subsection("Constraints, parameters and phases"), flags=re.S
    )[:2]
    assert "compendium" not in code, "the example uses the library alone"
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == printed.split()


def test_the_one_call_on_a_singular_arc_runs_and_prints_what_the_readme_shows(tmp_path):
    """The Goddard rocket with a speed limit, stated with the library alone: bang, singular, boundary and off arcs,
    the junctions of OptimalControl.jl's reference solution."""
    section = _section("The library on its own")
    blocks = re.findall(r"```(?:python)?\n(.*?)```", section, flags=re.S)
    index = next(k for k, b in enumerate(blocks) if "to_extremal(" in b)
    code, printed = blocks[index], blocks[index + 1]
    assert "compendium" not in code, "the example uses the library alone"
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert _same_print(proc.stdout, printed) == []
