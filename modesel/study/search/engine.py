"""The physics the search drives, injected: an `Engine`.

The default is `modesel.simulation.api`; tests inject a fake. Its functions
must be picklable (module-level functions) when trials run in parallel
processes.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class Engine:
    """The physics the search drives: `load_scene(path) -> Scene`,
    `simulate(scene, modeset, tmax=, dt=) -> SimulationResult` and,
    optionally, `channel_unit(name) -> unit or None` (the unit of an output
    channel, so references in incompatible units are refused before the search).
    selects_channels: `simulate` also takes channels= (the names a trial
    compares), and may leave the others out of its outputs."""

    load_scene: Callable
    simulate: Callable
    channel_unit: Callable | None = None
    selects_channels: bool = False


def default_engine() -> Engine:
    """The simulator of `modesel.simulation.api`."""
    from modesel.simulation import api
    return Engine(api.load_scene, api.simulate, api.channel_unit, selects_channels=True)


def resolve(engine: Engine | None) -> Engine:
    """`engine`, or the default one (looked up when called, so that it can be replaced)."""
    return engine if engine is not None else default_engine()
