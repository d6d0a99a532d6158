"""Hard case: tower torsion and a flexible high-speed shaft (the second
paper's two-spring drivetrain, eq. 17-20 and 47; model/template.py, model/effects/drivetrain.py).

The NREL 5-MW with tower fore-aft, side-side and torsion modes, a free rotor
and the low- and high-speed shafts as two springs around a rigid gearbox.
With a light gearbox (1e4 kg m^2 on the LSS side) the HSS mode sits near
94 Hz, two to three orders above the tower's 0.32 Hz: a stiff system, which
the engine integrates with the implicit method.

References: the drivetrain is checked against the free-free chain of three
inertias and two springs written out by hand (rotor: hub + blades about the
shaft; gearbox; generator N_g^2 GenIner), the torsion frequency (2 `fem`
torsion modes, which carry the RNA yaw inertia) against 12 smooth `linear`
torsion modes of the same scene.
"""
import numpy as np
import pytest
import scipy.linalg

from hardcase_tools import assert_method_justified, modes, scene, simulate
from modesel.simulation.api import linearize_scene

GEARBOX_INERTIA = 1.0e4      # kg m^2, LSS side


def stiff_scene(torsion=("fem", 2)):
    sc = scene("turbine_parked_free_decay")
    sc.modes = modes(tower_fa=("elastodyn", 1), tower_ss=("elastodyn", 1), tower_torsion=torsion)
    sc.free = ("GeAz", "DrTr")
    sc.initial = {"TTDspFA": 1.0, "TTDspSS": 0.5, "TTDspTwst": np.deg2rad(0.2), "RotSpeed": 5 * np.pi / 30}
    # no damping anywhere (structure and shafts), so the energy is conserved
    sc.effects = {"gravity": True, "geometric_stiffening": True, "damping": False,
                  "drivetrain": {"model": "two_spring", "gearbox_inertia": GEARBOX_INERTIA,
                                 "lss_damping": 0.0, "hss_damping": 0.0}}
    return sc


def chain_frequencies(turbine):
    """Natural frequencies [Hz] of rotor - LSS - gearbox - HSS - generator
    (LSS-referred), from the turbine data alone. Rotor inertia: hub plus
    int m r^2 cos^2(precone) ds over the blades (r from the shaft axis)."""
    b = turbine.blade
    s = np.linspace(0.0, b.length, 20001)
    r = (turbine.hub_radius + s) * np.cos(turbine.precone[0])
    j_blade = np.trapezoid(np.interp(s, b.span, b.mass) * r**2, s) + turbine.tip_mass[0] * r[-1] ** 2
    j_rotor = turbine.hub_inertia + turbine.num_blades * j_blade
    k = 2.0 * turbine.drivetrain_stiffness            # each shaft (effects/drivetrain.py defaults)
    K = np.array([[k, -k, 0.0], [-k, 2 * k, -k], [0.0, -k, k]])
    J = np.diag([j_rotor, GEARBOX_INERTIA, turbine.generator_inertia * turbine.gearbox_ratio**2])
    w2 = scipy.linalg.eigh(K, J, eigvals_only=True)
    return np.sqrt(np.clip(w2, 0.0, None)) / (2 * np.pi)


def test_drivetrain_and_torsion_frequencies_against_references():
    sc = stiff_scene()
    found = {}
    for m in linearize_scene(sc)[0]:
        found.setdefault(m.label, m.frequency_hz)
    chain = chain_frequencies(sc.turbine)
    # the HSS mode (gearbox between the shafts) hardly moves the tower: 1e-5
    assert found["HSSTw"] == pytest.approx(chain[2], rel=1e-5)          # 93.787 Hz
    # the LSS mode rocks the nacelle about the shaft (side-side coupling): 0.5 %
    assert found["DrTr"] == pytest.approx(chain[1], rel=5e-3)           # 2.232 vs 2.223 Hz
    assert found["HSSTw"] / min(found["TFA1"], found["TSS1"]) > 200      # two orders above
    rich = {}
    for m in linearize_scene(stiff_scene(("linear", 12)))[0]:
        rich.setdefault(m.label, m.frequency_hz)
    assert found["TTor1"] >= rich["TTor1"] * (1 - 1e-7)                  # Ritz: fewer modes, stiffer
    assert found["TTor1"] == pytest.approx(rich["TTor1"], rel=1e-3)      # 1.4925 Hz


def test_stiff_drivetrain_is_integrated_implicitly_and_conserves_energy():
    sc = stiff_scene()
    run = simulate(sc, tmax=0.2, dt=0.01)
    assert run.finite()
    assert_method_justified(run, sc)
    assert run.method in ("compiled-Radau", "Radau") and run.ratio > 200
    assert run.energy_drift() < 1e-6
    out = run.result.outputs
    assert np.ptp(out["Q_HSSTw"]) > 0 and np.ptp(out["Q_TTor1"]) > 0     # both coordinates moved


@pytest.mark.slow
def test_stiff_drivetrain_two_seconds():
    sc = stiff_scene(("fem", 6))
    run = simulate(sc, tmax=2.0, dt=0.01)
    assert run.finite()
    assert_method_justified(run, sc)
    assert run.energy_drift() < 1e-6
