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
    return text[start:end if end > 0 else None]


def test_library_example_runs_and_prints_what_the_readme_shows(tmp_path):
    section = _section("The library on its own")
    code, printed = re.findall(r"```(?:python)?\n(.*?)```", section, flags=re.S)[:2]
    assert "import ocpkit" in code or "from ocpkit" in code
    assert "compendium" not in code, "the example uses the library alone"
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == printed.split()


def test_library_example_matches_the_exact_cost(tmp_path):
    """J = 3/8 - sqrt(3)/12: the saturated-linear control u = 0.5 sat((t - 1.5) / sigma), sigma^2 = 3/4."""
    code = re.findall(r"```python\n(.*?)```", _section("The library on its own"), flags=re.S)[0]
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102
    exact = 3 / 8 - 3 ** 0.5 / 12
    assert abs(namespace["indirect"].objective - exact) < 1e-9
    for name in ("hlgl", "radau"):
        assert abs(namespace[name].objective - exact) < 1e-5, name
