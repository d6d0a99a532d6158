"""Structural damping of the flexible fields (on unless `damping = false`).

    [effects.damping]
    model = "modal"                   # or "stiffness_proportional"

"modal" (default): ElastoDyn's modal damping from the deck's ratios
(TwFADmp, TwSSDmp, BldFlDmp, BldEdDmp): D_il = zeta_l K_il / (pi f_l) with
f_l the field's own frequency of shape l (`flexible_beam.elastodyn_damping`,
first paper Appendix B). Tower torsion has no ElastoDyn ratio and takes the
first fore-aft one.

"stiffness_proportional": the second paper's Rayleigh functions (eq. 46-50),
R = 1/2 int c EI (d/dt u'')^2 with c = 2 zeta / lambda, i.e. per field

    D = (2 zeta / lambda_1) K

with lambda_1 [rad/s] the field's fundamental frequency (lowest eigenvalue
of its own K and M, beam only) and zeta the field's first deck ratio (the
paper uses one zeta_t for the tower fields and one zeta_b for the blades;
torsion takes the tower's fore-aft ratio). With one mode per field both
models give the same matrix.

The damping matrices are part of the flexible bodies (the engine applies
them), so this effect adds nothing at run time.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from modesel.model.effects.base import Effect, Option
from modesel.multibody.bodies import FlexibleBody
from modesel.vocabulary import is_blade_body, is_blade_field


class StructuralDamping(Effect):
    name = "damping"
    default_on = True
    OPTIONS = {"model": Option("choice", "modal", "damping model",
                               choices=("modal", "stiffness_proportional"))}

    def configure(self, spec):
        spec.damping = True

    def prepare(self, model):
        """`model` (modal damping, built in), or a new model whose flexible
        bodies carry the stiffness-proportional damping matrices."""
        if self.options["model"] != "stiffness_proportional":
            return model
        t = model.turbine
        bodies = []
        for body in model.system.bodies:
            if not isinstance(body, FlexibleBody):
                bodies.append(body)
                continue
            beam = t.blade if is_blade_body(body.name) else t.tower
            pos = {d: i for i, d in enumerate(body.dofs)}
            D = np.zeros_like(body.stiffness)
            for fld, dofs in model.field_dofs.items():
                if is_blade_field(fld):
                    dofs = next((ds for ds in dofs if ds and ds[0] in pos), ())
                if not dofs or dofs[0] not in pos:
                    continue
                sl = np.array([pos[d] for d in dofs])
                K = body.stiffness[np.ix_(sl, sl)]
                D[np.ix_(sl, sl)] = (2.0 * field_ratio(beam, fld) / fundamental(body, sl)) * K   # eq. 49-50
            bodies.append(replace(body, damping=D))
        return replace(model, system=replace(model.system, bodies=bodies))


def field_ratio(beam, fld) -> float:
    """First damping ratio of `fld` (torsion: the tower's fore-aft one)."""
    ratios = beam.damping_ratio.get(fld) or beam.damping_ratio.get("tower_fa") or [0.0]
    return float(ratios[0])


def fundamental(body, sl) -> float:
    """Lowest natural frequency [rad/s] of the coordinates `sl` of `body`
    alone (beam only, undeformed): K phi = lambda^2 M phi, M the field's own
    generalised mass (untwisted shapes, as the modal damping's field
    frequencies; `FlexibleBody.field_mass`)."""
    import scipy.linalg   # here: scipy.linalg costs a simulation 0.15 s of start-up

    if body.field_mass is not None:
        M = body.field_mass[np.ix_(sl, sl)]
        K = body.stiffness[np.ix_(sl, sl)]
        return float(np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True)[0]))
    Phi = body.shapes[:, :, sl]
    M = np.einsum("k,kil,kim->lm", body.node_mass, Phi, Phi)
    if body.torsion is not None and body.node_polar_inertia is not None:
        eta = body.torsion[:, sl]
        M = M + (eta * body.node_polar_inertia[:, None]).T @ eta
    K = body.stiffness[np.ix_(sl, sl)]
    return float(np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True)[0]))


EFFECT = StructuralDamping
