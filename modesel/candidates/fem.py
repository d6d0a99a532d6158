"""`fem`: modes of the real non-uniform beam from a finite-element eigen-analysis.

Uses `context.beam` (BeamProperties) and the finite elements of
`modesel.candidates.beam_fem`, root clamped:

* tower_fa / tower_ss: bending with EI = ei_1 / ei_2, the rotor-nacelle
  assembly as tip mass `context.tip_mass` and tip rotary inertia
  `context.tip_inertia` (about the bending axis at the tower top; the
  coupling of the RNA centre-of-mass height with the tip translation is not
  modelled, as in BModes/pyBmodes for a cantilever tower). With
  `gravity_factor` f > 0 the compression of the tower by its own weight and
  the tip mass softens it: N(s) = -f g [M_tip + int_s^L m ds'].
* blade_flap / blade_edge: bending with EI = ei_1 / ei_2 (structural twist
  ignored, as for ElastoDyn's mode shapes), rotating at
  Omega = `speed_factor` * context.rotor_speed. Centrifugal tension
  (first paper, eq. 29-30, with the precone beta):
      N(s) = Omega^2 cos^2(beta) [int_s^L m (r_h + s') ds' + M_tip (r_h + L)],
  the component along the coned blade of the centrifugal force
  Omega^2 (r_h + s) cos(beta) per unit mass; r_h = context.hub_radius.
  Spin softening (eq. 32): -Omega^2 M for edgewise (in-plane) motion and
  -Omega^2 sin^2(beta) M for flapwise motion.
* tower_torsion: linear torsion elements (GJ = gj, I_p = polar_inertia) with
  the RNA yaw inertia `context.tip_inertia` at the top.

Modes are returned lowest first, normalised to a unit tip value; phi, phi'
and phi'' come from the element interpolation (see `beam_fem`). Parameters
are continuous for a search: `elements` is rounded to the nearest integer.
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from modesel.candidates import beam_fem
from modesel.candidates.base import BENDING_FIELDS, TORSION_FIELDS, Family, Parameter, register
from modesel.errors import ModeselError
from modesel.vocabulary import is_blade_field

STIFFNESS = {"tower_fa": "ei_1", "tower_ss": "ei_2", "blade_flap": "ei_1", "blade_edge": "ei_2",
             "tower_torsion": "gj"}
INERTIA = {"tower_torsion": "polar_inertia"}
CACHE_SIZE = 64   # eigen-analyses kept: a search re-evaluates the same few configurations


def axial_force(span, mass, length, load_per_mass, tip_force):
    """N(s) = tip_force + int_s^L mass(s') load_per_mass(s') ds' as a callable,
    integrated with the trapezoidal rule on a fine grid (properties are linear
    between stations, so 4000 intervals give ~1e-7 relative accuracy)."""
    s = np.union1d(np.linspace(span[0], span[0] + length, 4001), span)
    q = np.interp(s, span, mass) * load_per_mass(s)
    tail = np.concatenate([np.cumsum((0.5 * (q[1:] + q[:-1]) * np.diff(s))[::-1])[::-1], [0.0]])
    n = tip_force + tail
    return lambda x: np.interp(x, s, n)


@register
class Fem(Family):
    name = "fem"
    description = ("modes of the real non-uniform beam: Hermite-cubic FE eigen-analysis (tower: RNA "
                   "tip mass/inertia, optional gravity; blades: centrifugal stiffening); torsion: "
                   "linear elements with RNA yaw inertia")
    fields = BENDING_FIELDS + TORSION_FIELDS
    parameters = (
        Parameter("elements", 60.0, 4.0, 400.0, "number of finite elements (rounded)"),
        Parameter("speed_factor", 1.0, 0.0, 2.0,
                  "blades: rotor speed as a multiple of context.rotor_speed (ignored elsewhere)"),
        Parameter("gravity_factor", 0.0, 0.0, 1.0,
                  "tower bending: fraction of gravity in the geometric softening (ignored elsewhere)"),
    )
    max_count = 40

    def __init__(self):
        self._cache = OrderedDict()

    def relevant_parameters(self, field):
        if is_blade_field(field):
            return ("elements", "speed_factor")
        if field in TORSION_FIELDS:
            return ("elements",)
        return ("elements", "gravity_factor")

    def canonical(self, field, count, params):
        """`elements` enters rounded to an integer; speed_factor only for blades,
        gravity_factor only for tower bending."""
        return super().canonical(field, count, dict(params, elements=float(round(params["elements"]))))

    def modal_analysis(self, context, count, params):
        """(omega [rad/s] (count,), element nodes [m], eigenvectors) of the field's beam.
        Results are cached on the values of everything they depend on."""
        beam = _checked_beam(context)
        key = _cache_key(context, beam, count, params)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        result = self._solve(context, beam, count, params)
        self._cache[key] = result
        if len(self._cache) > CACHE_SIZE:
            self._cache.popitem(last=False)
        return result

    def _solve(self, context, beam, count, params):
        field = context.field
        span = np.asarray(beam.span, dtype=float)
        length = float(span[-1] - span[0])
        n_el = int(round(params["elements"]))
        dofs = n_el if field in TORSION_FIELDS else 2 * n_el
        if count > dofs:
            raise ModeselError(f"family 'fem' with {n_el} elements has {dofs} modes, asked for {count}",
                               field="count")
        nodes = np.linspace(span[0], span[-1], n_el + 1)
        stiffness = np.asarray(getattr(beam, STIFFNESS[field]), dtype=float)
        if field in TORSION_FIELDS:
            k, m = beam_fem.torsion_matrices(nodes, span, np.asarray(beam.polar_inertia, float),
                                             stiffness, tip_inertia=context.tip_inertia)
        else:
            k, m = beam_fem.bending_matrices(nodes, span, np.asarray(beam.mass, float), stiffness,
                                             tip_mass=context.tip_mass,
                                             tip_inertia=context.tip_inertia,
                                             **_geometric_loads(context, span, beam.mass, length,
                                                                params))
        try:
            omega, vectors = beam_fem.lowest_modes(k, m, count)
        except ValueError as exc:
            raise ModeselError(str(exc), file=context.source, field=field) from None
        tip_row = -1 if field in TORSION_FIELDS else -2
        bad = ~beam_fem.tip_displacement_ok(vectors, tip_row)
        if bad.any():
            raise ModeselError(f"fem mode {int(np.argmax(bad)) + 1} has (almost) no tip motion and "
                               "cannot be normalised to a unit tip", file=context.source, field=field)
        for array in (omega, nodes, vectors):
            array.flags.writeable = False     # shared through the cache
        return omega, nodes, vectors

    def breakpoints(self, count, context, params):
        """Element boundaries (normalised): phi'' (bending) or phi' (torsion) jump there."""
        _, nodes, _ = self.modal_analysis(context, count, params)
        return (nodes[1:-1] - nodes[0]) / (nodes[-1] - nodes[0])

    def evaluate(self, x, count, context, params):
        _, nodes, vectors = self.modal_analysis(context, count, params)
        sample = beam_fem.sample_torsion if context.field in TORSION_FIELDS else beam_fem.sample_bending
        # stations are normalised on the flexible span, which starts at nodes[0]
        return sample(x, nodes, vectors)


def _geometric_loads(context, span, mass, length, params):
    """Keyword arguments (axial_force, spin_softening) of `bending_matrices`."""
    mass = np.asarray(mass, dtype=float)
    if is_blade_field(context.field):
        omega = params["speed_factor"] * context.rotor_speed
        if omega == 0.0:
            return {}
        c2 = np.cos(context.precone) ** 2
        r_hub = context.hub_radius
        tension = axial_force(span, mass, length,
                              lambda s: omega ** 2 * c2 * (r_hub + s - span[0]),
                              context.tip_mass * omega ** 2 * c2 * (r_hub + length))
        kappa = 1.0 if context.field == "blade_edge" else np.sin(context.precone) ** 2
        return {"axial_force": tension, "spin_softening": kappa * omega ** 2}
    g = params["gravity_factor"] * context.gravity
    if g == 0.0:
        return {}
    return {"axial_force": axial_force(span, mass, length, lambda s: -g * np.ones_like(s),
                                       -g * context.tip_mass)}


def _cache_key(context, beam, count, params):
    arrays = tuple(np.asarray(getattr(beam, name), dtype=float).tobytes()
                   for name in ("span", "mass", STIFFNESS[context.field], "polar_inertia"))
    return (context.field, arrays, context.tip_mass, context.tip_inertia, context.rotor_speed,
            context.hub_radius, context.precone, context.gravity, count,
            tuple(sorted(params.items())))


def _checked_beam(context):
    """context.beam with finite, positive properties, else a ModeselError."""
    beam = context.beam
    where = dict(file=context.source, field=context.field)
    if beam is None:
        raise ModeselError("family 'fem' needs the beam properties (context.beam)", **where)
    span = np.asarray(beam.span, dtype=float)
    if span.ndim != 1 or len(span) < 2 or np.any(np.diff(span) <= 0):
        raise ModeselError("beam stations must be at least 2 and strictly increasing", **where)
    names = ("mass", STIFFNESS[context.field]) + ((INERTIA[context.field],)
                                                  if context.field in INERTIA else ())
    for name in names:
        values = np.asarray(getattr(beam, name), dtype=float)
        if values.shape != span.shape or not np.all(np.isfinite(values)) or np.any(values <= 0):
            raise ModeselError(f"beam property '{name}' must be finite and > 0 at all "
                               f"{len(span)} stations", **where)
    if context.tip_mass < 0 or context.tip_inertia < 0:
        raise ModeselError("tip mass and tip inertia must be >= 0", **where)
    return beam
