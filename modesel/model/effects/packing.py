"""The record format of the compiled loads (`effects.compiled`): the kind
of each acting effect and the flat arrays (ints, floats, state) each one
packs its numbers into (`Effect.compile_loads`). No numba here, so that the
effects can pack without importing the compiled dispatch."""
from __future__ import annotations

import numpy as np

from modesel.aero.wind import GRID_SLOT, N_PARAMS

WIND, AERO, TOWER_DRAG, GENERATOR = 0, 1, 2, 3

#: state[CHANNEL_FLAG] != 0: the effects also write their output channels
#: that cost work (the aerodynamic rotor loads) into their channel slots;
#: set only for the pass over the output times (`CompiledRHS.outputs`)
CHANNEL_FLAG = N_PARAMS
assert GRID_SLOT == CHANNEL_FLAG + 1      # state[GRID_SLOT]: where a full field starts (0: none)


class Packer:
    """Accumulates the ints, floats and state of the load records."""

    def __init__(self):
        self.ints = [0]
        self.floats = []
        self.n_floats = 0
        self.n_state = GRID_SLOT + 1
        self.initial = {}
        self.channels = {}
        #: a record needs the tower influence's code (`effects.compiled.loads_function`)
        self.tower_influence = False

    def add(self, array) -> int:
        """Append an array to floats; its offset."""
        a = np.ascontiguousarray(array, float).ravel()
        off = self.n_floats
        self.floats.append(a)
        self.n_floats += a.size
        return off

    def scratch(self, size) -> int:
        """Reserve `size` state floats; their offset."""
        off = self.n_state
        self.n_state += int(size)
        return off

    def set_state(self, off, values):
        """Initial values of state floats from `off`."""
        self.initial[off] = np.asarray(values, float)

    def channel(self, name, off, scale=1.0):
        """Output channel `name` (OpenFAST's) is state[off] * scale after each
        evaluation with the channel flag set."""
        self.channels[name] = (int(off), float(scale))

    def record(self, kind, ints):
        self.ints += [kind, len(ints) + 2] + [int(i) for i in ints]
        self.ints[0] += 1

    def arrays(self):
        floats = np.concatenate(self.floats) if self.floats else np.zeros(0)
        state = np.zeros(self.n_state)
        for off, values in self.initial.items():
            state[off:off + len(values)] = values
        return np.array(self.ints, np.int64), np.ascontiguousarray(floats, float), state


def point_set_ints(packer, ps):
    """Ints of a `kinematics.PointSet` (body, count, ne, floats offset, idx...)."""
    off = packer.add(ps.s0)
    packer.add(ps.Phi)
    packer.add(ps.S)
    packer.add(ps.axis)
    return [ps.body, len(ps.s0), len(ps.idx), off] + list(ps.idx)
