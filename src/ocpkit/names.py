"""Names in the problem statement: the user's callables see states, controls and parameters by name.

Every callable of a problem statement (dynamics, costs, constraints, an expression to
sample on a solution) receives CasADi column vectors that also answer to the names the
problem declared::

    dynamics=lambda x, u, t: [x["v"], u["thrust"] / x["m"] - g]
    lagrange=lambda x, u, t, p: (x["h"] - p["h_ref"]) ** 2

``x["v"]`` is the state named ``"v"``; positions (``x[1]``, ``ca.vertsplit(x)``) still
work, and arithmetic gives ordinary CasADi expressions. Attribute access (``x.v``) is not
offered: a state named ``T`` would silently be the transpose. ``x.v`` for a declared name that is not one of CasADi's
attributes is an AttributeError naming the state, the callable and the fix ``x["v"]`` (:class:`NameAsAttribute`).

**One signature, whatever the parameters.** A callable receives the parameters ``p`` (fixed
and free, by name) when it needs one more argument than its inputs, ``(x, u, t, p)``, even
in a problem without parameters; one written ``(x, u, t)`` keeps working when the problem
gains a parameter it does not use. An optional last argument (``p=None``) receives them
when the problem has parameters.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import casadi as ca
import numpy as np


class UnknownName(KeyError):
    """A name a problem does not declare, asked of a :class:`Named` view (it says which names there are)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class NameAsAttribute(AttributeError):
    """A name asked of a :class:`Named` view as an attribute, ``x.v`` (it says to write ``x["v"]``)."""


class Named(ca.SX):
    """A CasADi column vector whose entries also answer to names: ``x["h"]`` (see the module docstring).

    ``label``: the argument it is given as (``"x"``, ``"xf"``), for the messages.
    """

    _names: tuple[str, ...]
    _kind: str
    _label: str

    def __init__(self, column: ca.SX, names: Sequence[str], kind: str = "variable", label: str = "x") -> None:
        super().__init__(column)
        if len(names) != column.numel():
            raise ValueError(f"{len(names)} names for {column.numel()} {kind} entries")
        object.__setattr__(self, "_names", tuple(names))
        object.__setattr__(self, "_kind", kind)
        object.__setattr__(self, "_label", label)

    def __getattr__(self, name: str) -> Any:
        # reached only where CasADi has no such attribute: x.T stays the transpose
        if name.startswith("_"):
            raise AttributeError(name)
        label, kind = self._label, self._kind
        if name in self._names:
            raise NameAsAttribute(
                f"{label}.{name} reads the {kind} {name!r} as an attribute: write {label}[{name!r}] "
                f"(attribute access is not offered: a {kind} named T would be the transpose)"
            )
        raise NameAsAttribute(
            f"{label} has no attribute {name!r}: the {kind}s are {list(self._names)}, read as {label}[name]"
        )

    @property
    def names(self) -> tuple[str, ...]:
        return self._names

    def __getitem__(self, key: Any) -> ca.SX:  # type: ignore[override]  # an entry is an SX (the stub says Self)
        if isinstance(key, str):
            if key not in self._names:
                raise UnknownName(f"unknown {self._kind} {key!r}; the {self._kind}s are {list(self._names)}")
            return ca.SX.__getitem__(self, self._names.index(key))
        return ca.SX.__getitem__(self, key)

    def __contains__(self, key: object) -> bool:
        return key in self._names

    def keys(self) -> tuple[str, ...]:
        return self._names


class NamedParameters(dict[str, Any]):
    """The parameters ``p`` of a problem's callables: a dict of CasADi symbols by name, as they always were
    (``p["k"]``, ``p.get("k")``, ``p.items()``), that also answers to positions (``p[0]``) and names an unknown name.

    (Not a :class:`Named` column: CasADi reads an SX subclass that iterates over its names as a list of them.)
    """

    def __init__(self, column: ca.SX, names: Sequence[str], kind: str = "parameter") -> None:
        if len(names) != column.numel():
            raise ValueError(f"{len(names)} names for {column.numel()} {kind} entries")
        super().__init__((name, column[i]) for i, name in enumerate(names))
        self._kind = kind
        self._column = column

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self)

    @property
    def column(self) -> ca.SX:
        """All of them as one CasADi column, in order."""
        return self._column

    def __getattr__(self, name: str) -> Any:
        # reached only where a dict has no such attribute: p.items stays the dict's
        if name.startswith("_"):
            raise AttributeError(name)
        if name in self:
            raise NameAsAttribute(
                f"p.{name} reads the {self._kind} {name!r} as an attribute: write p[{name!r}] (p is a dict by name)"
            )
        raise NameAsAttribute(f"p has no attribute {name!r}: the {self._kind}s are {list(self)}, read as p[name]")

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, (int, np.integer, slice)) and not isinstance(key, bool):
            return self._column[key]  # type: ignore[index]  # NumPy integers index too (the stub lists int)
        if key not in self:
            raise UnknownName(f"unknown {self._kind} {key!r}; the {self._kind}s are {list(self)}")
        return dict.__getitem__(self, key)


@contextmanager
def naming(what: str) -> Iterator[None]:
    """Say ``what`` asked for an unknown name (an :class:`UnknownName` from a view) or a name as an attribute (a
    :class:`NameAsAttribute`), chaining the original; any other error of the user's code goes through untouched."""
    try:
        yield
    except UnknownName as exc:
        raise UnknownName(f"{what}: {exc}") from exc
    except NameAsAttribute as exc:
        raise NameAsAttribute(f"{what}: {exc}") from exc


def argument_names(fn: Callable[..., Any], required: bool = False) -> list[str] | None:
    """The names of ``fn``'s positional arguments (``required``: only those without a default value, the ones a
    call must fill), or None where its signature cannot be read."""
    try:
        parameters = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return None
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    return [q.name for q in parameters if q.kind in kinds and not (required and q.default is not q.empty)]


def takes_parameters(
    fn: Callable[..., Any],
    inputs: int,
    what: str = "the callable",
    signature: Sequence[str] | None = None,
    hint: str = "",
) -> bool | None:
    """Whether ``fn`` takes the parameters after its ``inputs`` arguments: True when it needs them, False when it
    takes no more than its inputs, None when it may take them (a default value, ``*args``) or its signature cannot be
    read.

    A callable needing more than ``inputs + 1`` positional arguments, or taking fewer than ``inputs``, is a TypeError
    naming ``what``, the arguments it is called with (``signature``: their names) and ``hint`` (the fix).
    """
    try:
        parameters = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return None
    params = list(parameters.values())
    positional = [
        q for q in params if q.kind in (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    ]
    required = [q for q in positional if q.default is inspect.Parameter.empty]
    given = f"{inputs} ({', '.join(signature)})" if signature is not None else str(inputs)
    if len(required) > inputs + 1:
        raise TypeError(
            f"{what} needs {len(required)} arguments; it is given {given}, or {inputs + 1} with the parameters p "
            f"last{f': {hint}' if hint else ''}"
        )
    if len(required) > inputs:
        return True
    varargs = any(q.kind is inspect.Parameter.VAR_POSITIONAL for q in params)
    if len(positional) < inputs and not varargs:
        takes = ", ".join(q.name for q in positional)
        raise TypeError(
            f"{what} takes {len(positional)} argument{'s' if len(positional) != 1 else ''} ({takes}); it is called "
            f"with {given}, or {inputs + 1} with the parameters p last: {hint or 'write it with those arguments'}"
        )
    if len(positional) > inputs or varargs:
        return None
    return False


def call(
    fn: Callable[..., Any],
    inputs: Sequence[Any],
    p: Any,
    *,
    has_parameters: bool,
    what: str,
    signature: Sequence[str] | None = None,
    hint: str = "",
) -> Any:
    """``fn(*inputs)``, or ``fn(*inputs, p)`` when it takes the parameters (:func:`takes_parameters`; ``signature``:
    the inputs' names, and ``hint`` a fix, for its messages).

    One that may take them (``P=None``, ``*args``, an unreadable signature) gets them when the problem has parameters.
    An unknown name asked of a view is an :class:`UnknownName` that says ``what`` asked.
    """
    wants = takes_parameters(fn, len(inputs), what, signature, hint)
    if wants is None:
        wants = has_parameters
    with naming(what):
        return fn(*inputs, p) if wants else fn(*inputs)


__all__ = [
    "NameAsAttribute",
    "argument_names",
    "Named",
    "NamedParameters",
    "UnknownName",
    "call",
    "naming",
    "takes_parameters",
]
