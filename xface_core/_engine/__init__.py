"""The compiled docking engine (private): numba kernels cut along the solver's stages.

Modules, from the inside out: ``records`` (model, options, run state, work arrays, codes),
``pairs`` (vertex-edge geometry), ``motion`` (QP, corners, friction), ``integrate`` (a step
solved on the contacts or a Dormand-Prince step), ``bracket``, ``events`` and ``scan`` (root
bracketing, event functions, location, the earliest event), ``folds``, ``overlap``, ``ends``
(samples and ends), ``interval`` and ``segment`` (the stages), ``simulate`` (the stage
loop). The typed API is :mod:`xface_core.runner`.
"""

from __future__ import annotations

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

# Before anything compiles or loads from the cache: drop a cache built from other sources.
drop_stale_cache(getattr(getattr(simulate_many, "_cache", None), "_cache_path", None))

__all__ = [
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
