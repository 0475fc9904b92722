"""The transcription schemes by name: a study or a table chooses one by name, without a dispatch of its own.

A new scheme is registered here, after its module (:mod:`ocpkit.transcription.scheme` says what it provides).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..program.scheme import Scheme
from .hlgl import HLGL
from .multirate import MultiRateHLGL
from .radau import Radau

#: The schemes by name, ``"hlgl"`` (:class:`~ocpkit.transcription.hlgl.HLGL`), ``"radau"``
#: (:class:`~ocpkit.transcription.radau.Radau`), ``"multirate"``
#: (:class:`~ocpkit.transcription.multirate.MultiRateHLGL`).
SCHEMES: dict[str, Callable[..., Scheme]] = {"hlgl": HLGL, "radau": Radau, "multirate": MultiRateHLGL}


def scheme(name: str, *args: Any, **config: Any) -> Scheme:
    """The scheme named ``name`` (:data:`SCHEMES`, in any case: ``"HLGL"``, ``"radau"``) with its configuration,
    ``scheme("radau", nodes=4, intervals=20)``; given a problem first, the scheme bound to it
    (``scheme("hlgl", problem, intervals=20).solve()``)."""
    key = str(name).lower()
    if key not in SCHEMES:
        raise KeyError(f"unknown scheme {name!r}; the schemes are {sorted(SCHEMES)}")
    return SCHEMES[key](*args, **config)


__all__ = ["SCHEMES", "scheme"]
