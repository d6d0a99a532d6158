"""The `Effect` interface: one thing a scene switches on in its [effects]
table (a load, a controller, a model option), behind one small interface.

Life cycle, driven by `api.build` (hooks an effect does not need are no-ops):

1. `configure(spec)`: before the bodies exist, change the `BuildSpec`
   (DOF status, pitch, drivetrain form, ...).
2. `prepare(model)`: after the bodies exist, before the equations (e.g.
   damping matrices).
3. `setup(built)`: after the equations exist (precompute arrays).
4. `__call__(built, t, q_all, qd_all, generalized, node_forces)`: at every
   right-hand-side evaluation, add generalised forces to `generalized`
   (n_all,) [N or N m] and inertial-frame node forces [N] to
   `node_forces` {flexible body name: (N, 3)}; only for effects with
   `loads = True`.
5. `linear(built)`: generalised linear spring-dampers
   [(row, column, k, c)] over coordinate names, gen[row] -= k q[col] + c qd[col],
   which the compiled integrator applies itself.
6. `channels(built)`: output channels (OpenFAST names and units) from the
   last `__call__`.

An effect with a compiled form also has `compile_loads(built, packer,
packed)` (`effects/compiled.py`) and may offer `load_points(built)`.

Options: a scene gives `name = true` (defaults) or a table of options.
Each effect declares its `OPTIONS` ({key: Option}); `parse_options`
checks them and converts units, raising `ModeselError` naming the file and
`effects.<name>.<key>`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modesel.errors import ModeselError, did_you_mean


@dataclass
class Option:
    """One option of an effect: kind is "number", "bool", "choice", "path"
    or "series" ((time, value) pairs); `scale` converts the scene unit to SI
    (numbers, series values); `positive` / `nonnegative` bound numbers."""

    kind: str
    default: object = None
    doc: str = ""
    choices: tuple = ()
    scale: float = 1.0
    positive: bool = False
    nonnegative: bool = False


@dataclass
class BuildSpec:
    """What `models.build_turbine` receives, after the effects configured it.

    free (rigid DOFs), fixed {name: value}, prescribed {name: Prescribed},
    pitch [rad], drivetrain ("elastodyn" | "two_spring"), gearbox_inertia
    [kg m^2], damping (True: the deck's modal damping, False: none),
    reactions (add reaction coordinates), reaction_forces (and those of the
    forces and remaining moments, model/template.py)."""

    free: list
    fixed: dict
    prescribed: dict
    pitch: float = 0.0
    drivetrain: str = "elastodyn"
    gearbox_inertia: float = 0.0
    damping: bool = True
    reactions: bool = False
    reaction_forces: bool = False


class Effect:
    """Base class; subclasses set `name`, `OPTIONS`, `loads` and override hooks."""

    name = ""
    OPTIONS: dict = {}
    loads = False             # __call__ acts at every right-hand side
    #: its loads have kinks in the state (e.g. BEM on linearly interpolated
    #: polars), which "auto" integrates with a lower-order explicit method
    #: (`integrate.LOW_ORDER_RTOL`)
    kinked = False
    CHANNELS: tuple = ()      # the names `channels` returns (OpenFAST's)
    default_on = False        # switched on when the scene does not mention it

    def __init__(self, scene, options: dict):
        self.scene = scene
        self.options = options
        self.last = {}

    # -------------------------------------------------------------- selection
    @classmethod
    def applies(cls, scene) -> bool:
        """Switched on in `scene` ([effects] value true or a table)."""
        value = scene.effects.get(cls.name)
        if value is None:
            return cls.default_on_for(scene)
        return value is not False

    @classmethod
    def default_on_for(cls, scene) -> bool:
        return cls.default_on

    @classmethod
    def parse_options(cls, value, file=None, base_dir=None) -> dict:
        """Options in SI from the scene value (True or a table)."""
        where = f"effects.{cls.name}"
        if value is True or value is None:
            value = {}
        if not isinstance(value, dict):
            raise ModeselError("must be true, false or a table of options", file=file, field=where)
        for key in value:
            if key not in cls.OPTIONS:
                valid = ", ".join(cls.OPTIONS) or "none"
                raise ModeselError(f"unknown option '{key}'{did_you_mean(key, cls.OPTIONS)}; valid: {valid}",
                                   file=file, field=f"{where}.{key}")
        out = {}
        for key, opt in cls.OPTIONS.items():
            out[key] = _convert(opt, value.get(key, opt.default), file, f"{where}.{key}", base_dir,
                                key in value)
        return out

    # ------------------------------------------------------------------ hooks
    def configure(self, spec: BuildSpec) -> None:
        """Change the build specification (before the bodies exist)."""

    def prepare(self, model):
        """The turbine model this effect needs, before the equations exist:
        `model` itself, or a new model with other bodies (never a change of
        `model` in place)."""
        return model

    def setup(self, built) -> None:
        """Precompute what `__call__` needs (after the equations exist)."""

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces) -> None:
        """Add loads at time t [s] and state (q_all, qd_all) (all coordinates)."""

    def linear(self, built) -> list:
        """Linear generalised spring-dampers [(row, column, k, c)] or
        [(row, column, k, c, neutral)]: gen[row] -= k (q[column] - neutral) +
        c qd[column] (`multibody.compiled.CompiledRHS`)."""
        return []

    def load_points(self, built) -> dict:
        """{flexible body name: T (N, P)}: the node loads this effect puts on
        the body are T g for P point intensities g, so that the compiled loop
        may take them at P load points (`packing.with_load_points`; a body
        two effects offer keeps its nodes). `compile_loads` reads from
        `packed.load_points` whether it did; `packed.node_rows` refuses a
        body at load points to an effect that would load its nodes."""
        return {}

    def channels(self, built) -> dict:
        """Output channels from the last `__call__` (OpenFAST names/units; the
        names are the class's `CHANNELS`)."""
        return {}

    def error(self, message, key=None) -> ModeselError:
        return ModeselError(message, file=self.scene.path,
                            field=f"effects.{self.name}" + (f".{key}" if key else ""))


def _convert(opt: Option, value, file, where, base_dir, given):
    if value is None:
        return None
    if opt.kind == "bool":
        if not isinstance(value, bool):
            raise ModeselError(f"must be true or false, got {value!r}", file=file, field=where)
        return value
    if opt.kind == "choice":
        if value not in opt.choices:
            raise ModeselError(f"must be one of {', '.join(opt.choices)}, got {value!r}"
                               + did_you_mean(str(value), opt.choices), file=file, field=where)
        return value
    if opt.kind == "path":
        if not isinstance(value, str):
            raise ModeselError("must be a file path (string)", file=file, field=where)
        from pathlib import Path
        p = Path(value)
        if not p.is_absolute() and base_dir is not None and given:
            p = Path(base_dir) / p
        return str(p)
    if opt.kind == "series":
        try:
            arr = np.asarray(value, float)
        except (TypeError, ValueError):
            raise ModeselError("must be a list of [time, value] pairs", file=file, field=where) from None
        if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) < 1 or not np.all(np.isfinite(arr)):
            raise ModeselError("must be a list of [time, value] pairs of finite numbers", file=file, field=where)
        if np.any(np.diff(arr[:, 0]) <= 0):
            raise ModeselError("times must be strictly increasing", file=file, field=where)
        return np.column_stack([arr[:, 0], arr[:, 1] * opt.scale])
    # number
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise ModeselError(f"must be a finite number, got {value!r}", file=file, field=where)
    if opt.positive and value <= 0:
        raise ModeselError(f"must be positive, got {value!r}", file=file, field=where)
    if opt.nonnegative and value < 0:
        raise ModeselError(f"must be >= 0, got {value!r}", file=file, field=where)
    return float(value) * opt.scale
