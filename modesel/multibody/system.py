"""`System`: a tree of bodies plus the status of every coordinate.

Every coordinate named by a joint or a flexible body is one of
- free: integrated in time (the minimal coordinates q of the equations),
- fixed: held at a constant value (an ElastoDyn DOF switched off),
- prescribed: a given function of time (e.g. a rotor at constant speed).
The equations are assembled over all coordinates and restricted to the free
ones (first paper eq. 21-22); prescribed accelerations move to the right-hand side.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from modesel.multibody.bodies import FlexibleBody


@dataclass
class Prescribed:
    """q(t) = value + rate*t + 1/2 accel*t^2, or a callable t -> (q, qd, qdd)."""

    value: float = 0.0
    rate: float = 0.0
    accel: float = 0.0
    function: Callable | None = None

    def __call__(self, t: float):
        if self.function is not None:
            return self.function(t)
        return (self.value + self.rate * t + 0.5 * self.accel * t * t,
                self.rate + self.accel * t, self.accel)


@dataclass(frozen=True)
class GearboxLoss:
    """A lossy gearbox between the rotor and `body` (ElastoDyn's GBoxEff < 100 %):
    the generalised forces that reach coordinate `coordinate`'s equation
    through the gearbox (`body`'s inertia and every generalised force given
    on that coordinate: the generator torque) are divided by `efficiency`
    (0 < efficiency <= 1) while the low-speed shaft drives the gearbox and
    multiplied by it while the shaft is driven (`multibody.gearbox`)."""

    body: str
    coordinate: str
    efficiency: float


@dataclass
class System:
    """Bodies (parents before children) and coordinate status.

    `free`: ordered names of the free coordinates. `fixed`: {name: value}.
    `prescribed`: {name: Prescribed}. Any coordinate used by a body and not
    listed is fixed at 0. `gravity` [m/s^2] acts along -z of the ground frame.
    `gearbox_loss`: a `GearboxLoss`, or None for a lossless gearbox.
    """

    bodies: list
    free: list
    fixed: dict = field(default_factory=dict)
    prescribed: dict = field(default_factory=dict)
    gravity: float = 9.80665
    gearbox_loss: GearboxLoss | None = None

    def coordinate_names(self) -> list:
        """All coordinates: free first, then prescribed, then fixed/unlisted."""
        names = list(self.free)
        for n in self.prescribed:
            if n not in names:
                names.append(n)
        for n in self.fixed:
            if n not in names:
                names.append(n)
        for b in self.bodies:
            used = [d for r in b.joint.rotations for d in r.coeffs] + list(b.joint.translation)
            if b.joint.shortening is not None:
                used += list(b.joint.shortening.dofs)
            if isinstance(b, FlexibleBody):
                used += list(b.dofs)
            for d in used:
                if d not in names:
                    names.append(d)
        return names

    def body(self, name: str):
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    @property
    def n_free(self) -> int:
        return len(self.free)

    def flexible_bodies(self):
        return [b for b in self.bodies if isinstance(b, FlexibleBody)]
