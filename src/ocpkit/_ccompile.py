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
import platform
import shutil
import subprocess
import tempfile
from collections.abc import Iterable
from pathlib import Path

import casadi as ca

#: ``-ffp-contract=off``: no fused multiply-adds, so compiled code computes what CasADi's virtual machine does
CFLAGS = ["-O2", "-fPIC", "-shared", "-std=c99", "-ffp-contract=off"]

#: Generated C larger than this is compiled with ``-O1`` (gcc's time at ``-O2`` grows faster than the code's speed)
LARGE_SOURCE_BYTES = 200_000


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


def generate_c(functions: Iterable[ca.Function], name: str = "ocp_generated.c") -> str:
    """C source of CasADi ``functions`` (code generation, 64-bit integers, no header)."""
    with tempfile.TemporaryDirectory() as tmp:
        gen = ca.CodeGenerator(name, {"casadi_int": "long long", "casadi_real": "double", "with_header": False})
        for fun in functions:
            gen.add(fun)
        gen.generate(tmp + os.sep)
        return (Path(tmp) / name).read_text()


def shared_library(
    prefix: str, generated: str, sources: Iterable[str | os.PathLike[str]] = (), purpose: str = "ocpkit's C code"
) -> Path:
    """The library of ``generated`` C (and of the files ``sources``), compiled once and then found in the cache.

    Raises RuntimeError naming the compiler where it is missing or fails (``purpose``: what was compiled). The
    library is written next to its final name and renamed onto it (``os.replace``, atomic), so a process never sees
    half a library, and one already loaded by another process is never overwritten in place.
    """
    cc = compiler()
    if cc is None:
        raise RuntimeError(
            f"the C compiler {os.environ.get('CC', 'gcc')!r} was not found; compiling {purpose} needs one: install "
            "gcc or set CC"
        )
    paths = [Path(s) for s in sources]
    flags = list(CFLAGS)
    if len(generated) > LARGE_SOURCE_BYTES:
        flags[0] = "-O1"
    key_text = "\n".join(
        # (casadi sets __version__ at import; its stub omits it)
        [generated, *(s.read_text() for s in paths), cc, " ".join(flags), ca.__version__, platform.machine()]  # type: ignore[attr-defined]
    )
    key = hashlib.sha256(key_text.encode()).hexdigest()[:20]
    lib = cache_dir() / f"{prefix}_{key}.so"
    if lib.exists():
        return lib
    with tempfile.TemporaryDirectory() as tmp:
        gen_path = Path(tmp) / f"{prefix}_generated.c"
        gen_path.write_text(generated)
        fd, partial = tempfile.mkstemp(prefix=f".{lib.stem}.", suffix=".partial", dir=lib.parent)
        os.close(fd)
        try:
            cmd = [cc, *flags, "-o", partial, *(str(s) for s in paths), str(gen_path), "-lm"]
            proc = subprocess.run(cmd, capture_output=True, text=True)
            if proc.returncode != 0:
                raise RuntimeError(f"compiling {purpose} failed:\n{' '.join(cmd)}\n{proc.stderr[-4000:]}")
            os.replace(partial, lib)
        finally:
            if os.path.exists(partial):
                os.unlink(partial)
    return lib


def discard(lib: Path) -> None:
    """Remove a cached library that does not load (a broken file), so that the next call compiles it again."""
    try:
        os.unlink(lib)
    except FileNotFoundError:
        pass
