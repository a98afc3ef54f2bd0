"""The compiled docking engine (private): numba kernels cut along the solver's stages.

Modules, from the inside out: ``records`` (model, options, run state, work arrays, codes),
``pairs`` (vertex-edge geometry), ``motion`` (QP, corners, friction), ``integrate`` (a step
solved on the contacts or a Dormand-Prince step), ``bracket``, ``events`` and ``scan`` (root
bracketing, event functions, location, the earliest event), ``folds``, ``overlap``, ``ends``
(samples and ends), ``interval`` and ``segment`` (the stages), ``simulate`` (the stage
loop). The typed API is :mod:`xface_core.runner`. Every kernel's numba cache also reads the
precompiled engine shipped with the install (:mod:`.precompiled`).
"""

from __future__ import annotations

import sys
from typing import Any

from numba.core.dispatcher import Dispatcher

from . import pairs, precompiled
from ._stale import drop_stale_cache
from .overlap import overlapping
from .records import RUN_DTYPE, Model, Options, make_options
from .simulate import (
    lowest_reach,
    option_values,
    simulate_final,
    simulate_many,
    simulate_one,
    simulate_path,
    start_heights_of,
)

#: Every compiled kernel of the engine (the entry points and all they call), from every
#: module of the engine (``simulate`` imports them all).
KERNELS: tuple[Any, ...] = tuple(
    value
    for name, module in list(sys.modules.items())
    if name.startswith(f"{__name__}.")
    for value in vars(module).values()
    if isinstance(value, Dispatcher) and value.py_func.__module__ == name
)

#: The kernels called from Python (xface_core.runner, xface_core.contact): what a process
#: loads, or compiles, before its first answer (:func:`xface_core.runner.warm_up_engine`).
ENTRY_POINTS: tuple[Any, ...] = (  # numba Dispatchers (typed as the functions)
    simulate_final,
    simulate_path,
    simulate_many,
    start_heights_of,
    lowest_reach,
    pairs.fill_extents,
    pairs.eval_pair,
)

# Before anything compiles or loads from the cache: drop a cache built from other sources,
# then let every kernel's cache fall back to the precompiled engine of the install.
drop_stale_cache(getattr(getattr(simulate_many, "_cache", None), "_cache_path", None))
precompiled.install(list(KERNELS))

__all__ = [
    "ENTRY_POINTS",
    "KERNELS",
    "RUN_DTYPE",
    "Model",
    "Options",
    "lowest_reach",
    "make_options",
    "option_values",
    "overlapping",
    "simulate_final",
    "simulate_many",
    "simulate_one",
    "simulate_path",
    "start_heights_of",
]
