"""The coordinate vocabulary (modesel/vocabulary.py) and the mode labels
built on it (multibody/linearize.py): names round-trip, units match the
channels, labels follow modal participation and are unique."""
import numpy as np
import pytest

from modesel.model.outputs import channel_unit
from modesel.multibody.linearize import LinearModel, modes, unique_labels
from modesel.vocabulary import (BLADE_FIELDS, FIELD_DIRECTION, FIELDS, SCENE_DOFS, TOWER_FIELDS, Dof,
                                blade_dof_type, coordinate_field, dof_name, dof_unit, field_dofs,
                                multiblade_name, parse_dof)


@pytest.mark.parametrize("field", FIELDS)
def test_dof_names_round_trip(field):
    blade = 2 if field in BLADE_FIELDS else None
    for i, name in enumerate(field_dofs(field, 12, blade), 1):
        assert parse_dof(name) == Dof("elastic", blade, field, i)
        assert dof_name(field, i, blade) == name
    if blade is not None:
        key = blade_dof_type(dof_name(field, 3, 1))
        assert parse_dof(multiblade_name(key, "cos")) == Dof("elastic", None, field, 3, "cos")


def test_kinds_units_and_fields():
    assert [parse_dof(n).kind for n in ("DrTr", "HSSTw", "GeAz", "PtfmSurge", "TwrBsRyt", "RootRyc3")] == \
        ["drivetrain", "drivetrain", "rigid", "rigid", "reaction", "reaction"]
    assert parse_dof("RootRyc3").blade == 3
    # the reaction coordinates of the forces and remaining moments (model/template.py reaction_forces)
    for name in ("TwrBsTxt", "TwrBsRzt", "YawBrTyp", "YawBrRxp", "YawBrRzp", "RootTzc2", "RootRzc2"):
        assert parse_dof(name).kind == "reaction", name
    assert parse_dof("RootTxc2").blade == 2 and parse_dof("YawBrTzp").blade is None
    assert [dof_unit(n) for n in ("TFA1", "TTor2", "B3E1", "F1_sin", "PtfmSurge", "PtfmPitch", "DrTr")] == \
        ["m", "rad", "m", "m", "m", "rad", "rad"]
    assert dof_unit("TTor1", rate=True) == "rad/s" and dof_unit("B1F2", rate=True) == "m/s"
    assert coordinate_field("TSS2") == "tower_ss" and coordinate_field("HSSTw") == "drivetrain"
    assert coordinate_field("Yaw") is None
    for bad in ("B0F1", "TFA0", "X1", "F1_tan", "B1T1", "Q_TFA1"):
        with pytest.raises(ValueError):
            parse_dof(bad)
    assert set(SCENE_DOFS) <= {"GeAz", "DrTr", "Yaw", "PtfmSurge", "PtfmPitch"}
    assert set(FIELD_DIRECTION) == {f for f in FIELDS if f != "tower_torsion"}
    assert set(TOWER_FIELDS) | set(BLADE_FIELDS) == set(FIELDS)


def test_channel_units():
    assert [channel_unit(c) for c in ("Time", "Q_TFA1", "QD_TFA1", "Q_TTor1", "QD_GeAz", "Q_PtfmSurge",
                                      "OoPDefl3", "RootMyc1", "TwrBsMyt", "GenPwr", "NacYaw")] == \
        ["s", "m", "m/s", "rad", "rad/s", "m", "m", "kN-m", "kN-m", "kW", "deg"]
    assert channel_unit("Q_Nothing") is None and channel_unit("Unknown") is None


def three_inertia_chain(j_rotor=4e7, j_gearbox=1e4, j_generator=5e6, k=8.7e8):
    """Rotor - LSS - gearbox - HSS - generator in the model's coordinates:
    rotor angle GeAz + DrTr, gearbox GeAz + HSSTw, generator GeAz;
    LSS twist DrTr - HSSTw, HSS twist HSSTw (LSS-referred)."""
    T = np.array([[1.0, 1.0, 0.0], [1.0, 0.0, 1.0], [1.0, 0.0, 0.0]])       # body angles from (GeAz, DrTr, HSSTw)
    M = T.T @ np.diag([j_rotor, j_gearbox, j_generator]) @ T
    K = np.array([[0.0, 0.0, 0.0], [0.0, k, -k], [0.0, -k, 2 * k]])
    return LinearModel(["GeAz", "DrTr", "HSSTw"], M, np.zeros((3, 3)), K)


def test_drivetrain_modes_are_named_after_the_twisted_shaft():
    """The generator azimuth moves in both vibration modes (it carries the
    whole chain) but no stiffness acts on it, so it does not participate:
    the LSS mode is DrTr, the HSS (gearbox) mode HSSTw (the labels the
    hard case test_hard_drivetrain_torsion reads on the full turbine)."""
    lin = three_inertia_chain()
    found = modes(lin)
    assert [m.label for m in found] == ["DrTr", "HSSTw"]
    assert all(abs(m.shape[0]) > 0 and m.participation[0] < 1e-9 for m in found)
    assert [m.label for m in modes(lin, include_rigid=True)][0] == "GeAz"     # the free rotation


def test_repeated_modes_get_distinct_labels():
    """Three identical uncoupled oscillators (identical blades): one
    frequency three times, labelled by the three coordinates."""
    names = ["B1F1", "B2F1", "B3F1"]
    lin = LinearModel(names, np.eye(3), np.zeros((3, 3)), 4.0 * np.eye(3))
    found = modes(lin)
    assert sorted(m.label for m in found) == names
    assert all(m.frequency_hz == pytest.approx(1 / np.pi) for m in found)


def test_shared_dominant_coordinate_is_disambiguated():
    """Modes 0 and 1 are both dominated by x: the one where x participates
    most keeps 'x'; mode 1 takes its comparable second coordinate y (free);
    mode 2, dominated by x with a weak second w (which labels mode 3),
    becomes 'x+w'."""
    per_mode = np.array([[0.7, 0.2, 0.1], [0.45, 0.40, 0.15], [0.6, 0.15, 0.25], [0.1, 0.1, 0.8]])
    labels = unique_labels(["x", "y", "w"], per_mode, np.arange(4), per_mode, [0, 1, 2, 3])
    assert labels == {0: "x", 1: "y", 2: "x+w", 3: "w"}
