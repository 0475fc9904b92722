"""Compiling CasADi-generated C into a shared library, cached by the hash of what went into it.

One place for ocpkit's compiled code: the shooting engine's integrator (:mod:`ocpkit.shooting.compiled`) and the
NLP's derivative blocks (:mod:`ocpkit._compiled_blocks`). Libraries are compiled with the system's C compiler
(``CC``, default ``gcc``) and kept in ``OCPKIT_CACHE_DIR`` or the user's cache folder
(``$XDG_CACHE_HOME/ocpkit/shooting``, by default ``~/.cache/ocpkit/shooting``: the folder's name is that of its
first user), named by the hash of the generated source, the other sources, the compiler, its flags and CasADi's
version, so a library is compiled once per machine and found again by any process.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

CFLAGS = ["-O2", "-fPIC", "-shared", "-std=c99"]


def cache_dir() -> Path:
    """Where compiled libraries are kept: ``OCPKIT_CACHE_DIR``, else ``<user cache>/ocpkit/shooting``.

    The user cache is ``$XDG_CACHE_HOME`` or ``~/.cache`` (the XDG convention, which
    Linux and most Unix tools follow).
    """
    env = os.environ.get("OCPKIT_CACHE_DIR")
    if env:
        path = Path(env)
    else:
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        path = Path(base) / "ocpkit" / "shooting"
    path.mkdir(parents=True, exist_ok=True)
    return path


def compiler() -> str | None:
    """The C compiler (``CC``, default ``gcc``), or None where it is not found."""
    cc = os.environ.get("CC", "gcc")
    return cc if shutil.which(cc) is not None else None


def generate_c(functions, name: str = "ocp_generated.c") -> str:
    """C source of CasADi ``functions`` (code generation, 64-bit integers, no header)."""
    with tempfile.TemporaryDirectory() as tmp:
        gen = ca.CodeGenerator(name, {"casadi_int": "long long", "casadi_real": "double", "with_header": False})
        for fun in functions:
            gen.add(fun)
        gen.generate(tmp + os.sep)
        return (Path(tmp) / name).read_text()


def shared_library(prefix: str, generated: str, sources=(), purpose: str = "ocpkit's C code") -> Path:
    """The library of ``generated`` C (and of the files ``sources``), compiled once and then found in the cache.

    Raises RuntimeError naming the compiler where it is missing or fails (``purpose``: what was compiled).
    """
    cc = compiler()
    if cc is None:
        raise RuntimeError(
            f"the C compiler {os.environ.get('CC', 'gcc')!r} was not found; compiling {purpose} needs one: install "
            "gcc or set CC"
        )
    sources = [Path(s) for s in sources]
    key_text = "\n".join([generated, *(s.read_text() for s in sources), cc, " ".join(CFLAGS), ca.__version__])
    key = hashlib.sha256(key_text.encode()).hexdigest()[:20]
    lib = cache_dir() / f"{prefix}_{key}.so"
    if lib.exists():
        return lib
    with tempfile.TemporaryDirectory() as tmp:
        gen_path = Path(tmp) / f"{prefix}_generated.c"
        gen_path.write_text(generated)
        out = Path(tmp) / lib.name
        cmd = [cc, *CFLAGS, "-o", str(out), *(str(s) for s in sources), str(gen_path), "-lm"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"compiling {purpose} failed:\n{' '.join(cmd)}\n{proc.stderr[-4000:]}")
        shutil.move(str(out), lib)  # atomic within one file system, so concurrent builds cannot see half a file
    return lib
