"""binder/ (what mybinder.org builds the compendium with) agrees with environment.txt, the notebooks and the venv;
CITATION.cff is valid and cites the sources.

The pre-compilation step of binder/postBuild is run for real against a temporary cache (about 12 s).
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shlex
import shutil
import stat
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.specifiers import SpecifierSet
from packaging.version import Version

from compendium.notebooks import KERNEL_NAME
from compendium.paths import notebooks_dir, repo_root
from compendium.provenance import ONE_THREAD

ROOT = repo_root()
BINDER = ROOT / "binder"
POSTBUILD = BINDER / "postBuild"
PIN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*==[A-Za-z0-9.+!_-]+$")


def _requirements(path: Path, seen: tuple[Path, ...] = ()) -> list[str]:
    """The requirement lines of a pip requirements file, nested ``-r`` files read relative to the file holding them."""
    path = path.resolve()
    assert path not in seen, f"-r cycle through {path}"
    lines = []
    for raw in path.read_text().splitlines():
        line = re.sub(r"(^|\s)#.*$", "", raw).strip()
        if not line:
            continue
        nested = re.match(r"^(?:-r|--requirement)(?:\s+|=)(.+)$", line)
        if nested:
            lines += _requirements(path.parent / nested.group(1).strip(), (*seen, path))
        else:
            lines.append(line)
    return lines


def _pins(lines: list[str]) -> dict[str, str]:
    pins = {}
    for line in lines:
        assert PIN.match(line), f"not an exact pin: {line!r}"
        name, version = line.split("==")
        key = re.sub(r"[-_.]+", "-", name).lower()  # PEP 503 names: one package, one pin
        assert key not in pins, f"{name} pinned twice"
        pins[key] = version
    return pins


def test_binder_requirements_are_exactly_the_environment_pins():
    binder = _requirements(BINDER / "requirements.txt")
    environment = _requirements(ROOT / "environment.txt")
    assert len(environment) > 50  # the whole resolved environment, not just the direct dependencies
    assert binder == environment
    assert _pins(binder) == _pins(environment)


def test_requirements_follow_nested_files_relative_to_their_folder(tmp_path, monkeypatch):
    (tmp_path / "sub").mkdir()
    (tmp_path / "base.txt").write_text("numpy==2.0.0  # a comment\n\n")
    (tmp_path / "sub" / "req.txt").write_text("# header\n-r ../base.txt\nscipy==1.0.0\n")
    monkeypatch.chdir(tmp_path / "sub")
    assert _requirements(tmp_path / "sub" / "req.txt") == ["numpy==2.0.0", "scipy==1.0.0"]


def _runtime_version() -> str:
    text = (BINDER / "runtime.txt").read_text().strip()
    match = re.fullmatch(r"python-(\d+\.\d+)", text)
    assert match, f"binder/runtime.txt should read python-X.Y, not {text!r}"
    return match.group(1)


def test_runtime_is_the_python_of_the_environment():
    version = _runtime_version()
    # the interpreter the tests (and CI, and `make setup`'s venv) run on
    assert version == f"{sys.version_info.major}.{sys.version_info.minor}"
    # what environment.txt says it was resolved for
    stated = re.search(r"\(Python (\d+\.\d+)\)", (ROOT / "environment.txt").read_text())
    assert stated and stated.group(1) == version
    requires = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"].get("requires-python")
    if requires:
        assert Version(version) in SpecifierSet(requires), (version, requires)


def _postbuild_commands() -> list[list[str]]:
    """postBuild's shell commands (outside the heredoc), as argument lists with continuation lines joined."""
    text = POSTBUILD.read_text()
    text = re.sub(r"<<'(\w+)'\n.*?\n\1\n", "\n", text, flags=re.S)  # drop heredoc bodies
    text = text.replace("\\\n", " ")
    commands = []
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            commands.append(shlex.split(line, comments=True))
    return commands


def test_postbuild_is_an_executable_strict_bash_script():
    mode = POSTBUILD.stat().st_mode
    assert mode & stat.S_IXUSR, "repo2docker runs postBuild only if it is executable (git update-index --chmod=+x)"
    lines = POSTBUILD.read_text().splitlines()
    assert lines[0] in {"#!/bin/bash", "#!/usr/bin/env bash"}
    assert ["set", "-euo", "pipefail"] in _postbuild_commands()
    if shutil.which("bash"):
        subprocess.run(["bash", "-n", str(POSTBUILD)], check=True)  # parses


def test_postbuild_installs_the_notebooks_kernel():
    installs = [c for c in _postbuild_commands() if c[1:5] == ["-m", "ipykernel", "install", "--sys-prefix"]]
    assert len(installs) == 1, installs
    args = installs[0]
    assert args[args.index("--name") + 1] == KERNEL_NAME
    assert args[args.index("--display-name") + 1] == "Python (ocpkit)"
    env = {args[i + 1]: args[i + 2] for i, a in enumerate(args) if a == "--env"}
    assert env == ONE_THREAD, "Binder's kernel computes with the published record's threads"


def test_postbuild_installs_ocpkit_without_dependencies():
    pips = [c for c in _postbuild_commands() if c[1:4] == ["-m", "pip", "install"]]
    assert pips, "postBuild should install ocpkit itself"
    for args in pips:
        assert "--no-deps" in args, args  # every dependency comes pinned from environment.txt
        assert "-e" in args and args[-1] == "."


def test_postbuild_uninstalls_what_environment_txt_leaves_out():
    """pip, which repo2docker installs binder/requirements.txt with, cannot leave a dependency out as uv does."""
    spec = importlib.util.spec_from_file_location("bootstrap_for_binder", ROOT / "src" / "compendium" / "bootstrap.py")
    bootstrap = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = bootstrap  # for its dataclasses
    try:
        spec.loader.exec_module(bootstrap)
    finally:
        del sys.modules[spec.name]
    uninstalls = [c for c in _postbuild_commands() if c[1:4] == ["-m", "pip", "uninstall"]]
    assert len(uninstalls) == 1, uninstalls
    names = [a for a in uninstalls[0][4:] if not a.startswith("-")]
    assert names == bootstrap.left_out(ROOT / "environment.txt") != []


@pytest.mark.parametrize("path", sorted(notebooks_dir().glob("*.ipynb")), ids=lambda p: p.name)
def test_notebook_names_the_compendium_kernel(path):
    spec = json.loads(path.read_text())["metadata"]["kernelspec"]
    assert spec["name"] == KERNEL_NAME
    assert spec["display_name"] == "Python (ocpkit)"


def _precompile_script() -> str:
    match = re.search(r"<<'PRECOMPILE'\n(.*?)\nPRECOMPILE\n", POSTBUILD.read_text(), flags=re.S)
    assert match, "postBuild's PRECOMPILE heredoc is missing"
    return match.group(1)


@pytest.mark.skipif(shutil.which(os.environ.get("CC", "gcc")) is None, reason="no C compiler")
def test_postbuild_precompiles_the_shooting_integrators(tmp_path):
    cache = tmp_path / "cache"
    env = {**os.environ, "OCPKIT_CACHE_DIR": str(cache), "XDG_CACHE_HOME": str(tmp_path / "xdg")}
    result = subprocess.run(
        [sys.executable, "-c", _precompile_script()],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-4000:]
    match = re.search(r"pre-compiled (\d+) shooting integrators into (\S+) in", result.stdout)
    assert match, result.stdout
    count, where = int(match.group(1)), Path(match.group(2))
    assert where == cache
    libraries = sorted(cache.glob("*.so"))
    assert count == len(libraries) >= 6  # notebook 04: two systems x two laws; notebook 05: three flows
    assert not (tmp_path / "xdg").exists()  # OCPKIT_CACHE_DIR wins over the user cache


# -- CITATION.cff --------------------------------------------------------------------------------------------------


def test_citation_file_describes_the_compendium_and_its_sources():
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0"
    assert cff["title"].startswith("ocpkit")
    assert cff["license"] == "BSD-3-Clause"
    assert cff["authors"] and all("name" in a or "family-names" in a for a in cff["authors"])
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert str(cff["version"]) == version
    references = cff["references"]
    assert len(references) == 4
    for ref in references:
        assert {"type", "title", "authors"} <= set(ref), ref
        assert ref["authors"] and all("name" in a or "family-names" in a for a in ref["authors"]), ref
    titles = [ref["title"].lower() for ref in references]
    for expected in (
        "a two-timescale discretization scheme for collocation",
        "an improved switching detection for an optimal control problem with control discontinuities",
        "fuel optimal entry trajectory with radau pseudospectral method and non-linear programming",
        "direct optimization using collocation based on high-order gauss-lobatto quadrature rules",
    ):
        assert expected in titles, expected


def test_license_is_bsd_3_clause():
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("BSD 3-Clause License")
    assert "Copyright (c) 2026, the ocpkit compendium authors" in text
    assert "Neither the name of the copyright holder nor the names of its" in text
