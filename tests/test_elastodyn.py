"""ElastoDyn deck reader: every value against the deck text, SI conversions,
.fst handling, normalisation for openfast_io, and errors naming file and field."""
import shutil
from pathlib import Path

import numpy as np
import pytest
from openfast_io.FAST_writer import InputWriter_OpenFAST

from modesel.errors import ModeselError
from modesel.turbine import elastodyn
from modesel.turbine.elastodyn import load_turbine, read_elastodyn

ROOT = Path(__file__).resolve().parent.parent
NREL = ROOT / "modesel" / "turbine" / "data" / "nrel5mw"
ED = NREL / "NREL5MW_ED_Onshore.dat"
TOWER = NREL / "NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat"
BLADE = NREL / "NRELOffshrBsline5MW_Blade.dat"
SPAR = ROOT / "tests" / "data" / "openfast_free_decay" / "tower_fa_ss_shaft"


# --- the deck text, read independently of the code under test ---------------

def text_value(path, label):
    """First token of the line whose second token is `label`."""
    for line in Path(path).read_text().splitlines():
        tokens = line.split()
        if len(tokens) > 1 and tokens[1] == label:
            return tokens[0]
    raise KeyError(label)


def text_float(path, label):
    return float(text_value(path, label))


def text_table(path, first_column):
    """{column name: array} of the station table whose header starts with first_column."""
    lines = Path(path).read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.split()[:1] == [first_column])
    names = lines[start].split()
    rows = []
    for line in lines[start + 2:]:
        try:
            rows.append([float(v) for v in line.split()])
        except ValueError:
            break
    table = np.array(rows)
    return {name: table[:, k] for k, name in enumerate(names)}


@pytest.fixture(scope="module")
def nrel():
    return load_turbine("nrel5mw")


def test_builtin_name_is_the_onshore_deck(nrel):
    assert Path(nrel.source) == ED


def test_scalars_equal_deck_text_in_si(nrel):
    f = lambda label: text_float(ED, label)  # noqa: E731
    deg = np.pi / 180
    assert nrel.num_blades == 3
    assert nrel.tower_height == f("TowerHt") == 87.6
    assert nrel.tower_base_height == f("TowerBsHt")
    assert nrel.tip_radius == f("TipRad") and nrel.hub_radius == f("HubRad")
    assert nrel.precone == pytest.approx([f(f"PreCone({k})") * deg for k in (1, 2, 3)])
    assert nrel.precone[0] == pytest.approx(-2.5 * deg)
    assert nrel.shaft_tilt == pytest.approx(f("ShftTilt") * deg)
    assert nrel.overhang == f("OverHang") and nrel.twr2shft == f("Twr2Shft")
    assert nrel.nacelle_cm == (f("NacCMxn"), f("NacCMyn"), f("NacCMzn"))
    assert nrel.hub_cm == f("HubCM")
    assert nrel.hub_mass == f("HubMass") == 56780.0
    assert nrel.hub_inertia == f("HubIner") and nrel.generator_inertia == f("GenIner")
    assert nrel.nacelle_mass == f("NacMass") == 240000.0
    assert nrel.nacelle_yaw_inertia == f("NacYIner") and nrel.yaw_bearing_mass == f("YawBrMass")
    assert nrel.tip_mass == tuple(f(f"TipMass({k})") for k in (1, 2, 3))
    assert nrel.platform_mass == f("PtfmMass")
    assert nrel.platform_inertia == (f("PtfmRIner"), f("PtfmPIner"), f("PtfmYIner"))
    assert nrel.platform_cm == (f("PtfmCMxt"), f("PtfmCMyt"), f("PtfmCMzt"))
    assert nrel.platform_ref_z == f("PtfmRefzt")
    assert nrel.gearbox_ratio == f("GBRatio") == 97.0
    assert nrel.gearbox_efficiency == pytest.approx(f("GBoxEff") / 100)
    assert nrel.drivetrain_stiffness == f("DTTorSpr") and nrel.drivetrain_damping == f("DTTorDmp")


def test_dofs_and_initial_conditions(nrel):
    for label in ("FlapDOF1", "FlapDOF2", "EdgeDOF", "TeetDOF", "DrTrDOF", "GenDOF", "YawDOF",
                  "TwFADOF1", "TwFADOF2", "TwSSDOF1", "TwSSDOF2", "PtfmSgDOF", "PtfmYDOF"):
        assert nrel.dofs[label] is (text_value(ED, label) == "True")
    assert "PitchDOF" not in nrel.dofs          # not in this (older) deck
    ini = nrel.initial
    assert ini["RotSpeed"] == pytest.approx(text_float(ED, "RotSpeed") * 2 * np.pi / 60)   # 10 rpm
    assert ini["RotSpeed"] == pytest.approx(1.0471975511965976)
    assert ini["Azimuth"] == pytest.approx(np.deg2rad(text_float(ED, "Azimuth")))
    assert ini["BlPitch"] == pytest.approx([np.deg2rad(text_float(ED, f"BlPitch({k})")) for k in (1, 2, 3)])
    assert ini["TTDspFA"] == text_float(ED, "TTDspFA") and ini["OoPDefl"] == text_float(ED, "OoPDefl")


def test_tower_properties_with_adjustments(nrel):
    table = text_table(TOWER, "HtFract")
    tw = nrel.tower
    assert tw.name == "tower" and tw.root_offset == 0.0
    assert np.allclose(tw.span, table["HtFract"] * (87.6 - 0.0))
    assert np.allclose(tw.mass, table["TMassDen"] * text_float(TOWER, "AdjTwMa"))
    assert np.allclose(tw.ei_1, table["TwFAStif"] * text_float(TOWER, "AdjFASt"))
    assert np.allclose(tw.ei_2, table["TwSSStif"] * text_float(TOWER, "AdjSSSt"))
    assert tw.damping_ratio == {"tower_fa": [0.01, 0.01], "tower_ss": [0.01, 0.01]}  # 1 % in the deck
    assert tw.stiffness_tuners == {"tower_fa": [1.0, 1.0], "tower_ss": [1.0, 1.0]}
    # documented torsion default: thin-walled steel tube, GJ = EI/(1+nu), rho J = 2 rho EI / E
    assert np.allclose(tw.gj, tw.ei_1 / 1.3)
    assert np.allclose(tw.polar_inertia, 2 * 8500.0 * tw.ei_1 / 210e9)
    assert any("torsion" in n for n in tw.notes)
    assert tw.total_mass == pytest.approx(347460.2316, rel=1e-9)   # trapezoid of the deck's TMassDen


def test_blade_properties_with_adjustments(nrel):
    table = text_table(BLADE, "BlFract")
    bl = nrel.blade
    adj = text_float(BLADE, "AdjBlMs")
    assert adj == 1.04536
    assert bl.root_offset == 1.5
    assert np.allclose(bl.span, table["BlFract"] * (63.0 - 1.5))
    assert np.allclose(bl.mass, table["BMassDen"] * adj)
    assert np.allclose(bl.ei_1, table["FlpStff"] * text_float(BLADE, "AdjFlSt"))
    assert np.allclose(bl.ei_2, table["EdgStff"] * text_float(BLADE, "AdjEdSt"))
    # the deck's PitchAxis column is not mistaken for StrcTwst (13.308 deg at the root)
    assert np.allclose(bl.twist, np.deg2rad(table["StrcTwst"]))
    assert bl.twist[0] == pytest.approx(np.deg2rad(13.308))
    assert bl.damping_ratio == {"blade_flap": [0.00477465, 0.00477465], "blade_edge": [0.00477465]}
    assert bl.stiffness_tuners == {"blade_flap": [1.0, 1.0]}
    assert np.all(bl.gj == 0) and any("torsion" in n for n in bl.notes)   # documented, not silent


def test_mode_shape_coefficients(nrel):
    def coeffs(path, name):
        return [text_float(path, f"{name}({k})") for k in range(2, 7)]
    shapes = nrel.elastodyn_shapes
    assert shapes["tower_fa"] == [coeffs(TOWER, "TwFAM1Sh"), coeffs(TOWER, "TwFAM2Sh")]
    assert shapes["tower_ss"] == [coeffs(TOWER, "TwSSM1Sh"), coeffs(TOWER, "TwSSM2Sh")]
    assert shapes["blade_flap"] == [coeffs(BLADE, "BldFl1Sh"), coeffs(BLADE, "BldFl2Sh")]
    assert shapes["blade_edge"] == [coeffs(BLADE, "BldEdgSh")]
    assert shapes["tower_fa"][0] == [0.7004, 2.1963, -5.6202, 6.2275, -2.504]   # first paper, eq. 46


def test_gravity_missing_from_older_deck_is_noted(nrel):
    assert nrel.gravity == 9.80665
    assert any("Gravity" in n for n in nrel.notes)
    assert any("PitchDOF" in n for n in nrel.notes)       # neutral value, recorded


def test_fst_follows_edfile_and_older_ed_gravity():
    t = read_elastodyn(SPAR / "Main_Spar_ED.fst")
    ed = SPAR / "Spar_ED_ForED.dat"
    assert t.gravity == text_float(ed, "Gravity")
    assert t.tower_base_height == 20.0 and t.tower.span[-1] == pytest.approx(87.6 - 20.0)
    assert t.initial["TTDspFA"] == 2.0 and t.initial["TTDspSS"] == -2.0
    assert t.dofs["TwFADOF1"] and t.dofs["TwSSDOF1"] and t.dofs["GenDOF"]
    assert not t.dofs["TwFADOF2"] and not t.dofs["FlapDOF1"] and not t.dofs["DrTrDOF"]
    assert t.generator_inertia == 0.0


def test_fst_gravity_takes_precedence(tmp_path):
    lines = (SPAR / "Main_Spar_ED.fst").read_text().splitlines()
    out = []
    for line in lines:
        if line.split()[1:2] == ["EDFile"]:
            line = f'"{SPAR / "Spar_ED_ForED.dat"}"   EDFile   - ElastoDyn file'
        out.append(line)
        if line.split()[1:2] == ["CompIce"]:
            out += ["---------------------- ENVIRONMENTAL CONDITIONS ------------",
                    "   9.81   Gravity   - Gravitational acceleration (m/s^2)"]
    fst = tmp_path / "with_gravity.fst"
    fst.write_text("\n".join(out) + "\n")
    assert read_elastodyn(fst).gravity == 9.81


def test_new_format_deck_reads_the_same(tmp_path, nrel):
    """Round trip through openfast_io's own writer (newest layout, no
    normalisation needed): the turbine is unchanged."""
    values, _ = elastodyn.read_deck(ED, "elastodyn")
    tower, _ = elastodyn.read_deck(TOWER, "tower")
    blade, _ = elastodyn.read_deck(BLADE, "blade")
    writer = InputWriter_OpenFAST()
    writer.FAST_runDirectory, writer.FAST_namingOut = str(tmp_path), "new"
    reader_outlist = {"ElastoDyn": {}, "ElastoDyn_Nodes": {}}
    writer.fst_vt = {"Fst": {}, "ElastoDyn": dict(values), "ElastoDynTower": dict(tower),
                     "ElastoDynBlade": dict(blade), "outlist": reader_outlist}
    writer.fst_vt["ElastoDyn"].pop("BldNd_BladesOut", None)
    writer.write_ElastoDynBlade()
    writer.write_ElastoDynTower()
    writer.write_ElastoDyn()
    new = read_elastodyn(tmp_path / writer.fst_vt["Fst"]["EDFile"])
    assert not any("predates" in n for n in new.notes)
    for name in ("tower_height", "hub_mass", "nacelle_mass", "precone", "shaft_tilt", "gearbox_ratio",
                 "drivetrain_stiffness", "initial", "elastodyn_shapes"):
        assert getattr(new, name) == getattr(nrel, name), name
    for beam in ("tower", "blade"):
        a, b = getattr(new, beam), getattr(nrel, beam)
        for arr in ("span", "mass", "ei_1", "ei_2", "twist"):
            assert np.allclose(getattr(a, arr), getattr(b, arr), rtol=1e-12), (beam, arr)
    assert new.dofs["PitchDOF"] is False


# --- errors name the file and the field ---------------------------------------

def copy_deck(tmp_path):
    for f in (ED, TOWER, BLADE):
        shutil.copy(f, tmp_path / f.name)
    return tmp_path / ED.name


def replace_line(path, label, new_value):
    lines = path.read_text().splitlines()
    for i, line in enumerate(lines):
        if line.split()[1:2] == [label]:
            lines[i] = f"{new_value}   {label}   - edited"
    path.write_text("\n".join(lines) + "\n")


def test_file_not_found(tmp_path):
    with pytest.raises(ModeselError, match="missing.dat.*not found"):
        read_elastodyn(tmp_path / "missing.dat")
    with pytest.raises(ModeselError, match="no_such_turbine"):
        load_turbine("no_such_turbine")


def test_referenced_tower_file_missing(tmp_path):
    main = copy_deck(tmp_path)
    (tmp_path / TOWER.name).unlink()
    with pytest.raises(ModeselError) as err:
        read_elastodyn(main)
    assert err.value.file == str(main) and err.value.field == "TwrFile"
    assert TOWER.name in str(err.value)


def test_referenced_blade_file_missing(tmp_path):
    main = copy_deck(tmp_path)
    (tmp_path / BLADE.name).unlink()
    with pytest.raises(ModeselError) as err:
        read_elastodyn(main)
    assert err.value.field == "BldFile(1)"


def test_missing_station_table(tmp_path):
    main = copy_deck(tmp_path)
    tower = tmp_path / TOWER.name
    lines = tower.read_text().splitlines()
    start = next(i for i, l in enumerate(lines) if l.split()[:1] == ["HtFract"])
    del lines[start:start + 2 + 11]                  # header, units and the 11 stations
    tower.write_text("\n".join(lines) + "\n")
    with pytest.raises(ModeselError) as err:
        read_elastodyn(main)
    assert err.value.file == str(tower) and err.value.field == "HtFract"


def test_short_station_table(tmp_path):
    main = copy_deck(tmp_path)
    blade = tmp_path / BLADE.name
    lines = blade.read_text().splitlines()
    start = next(i for i, l in enumerate(lines) if l.split()[:1] == ["BlFract"])
    del lines[start + 2 + 47:start + 2 + 49]          # 47 of the 49 rows left
    blade.write_text("\n".join(lines) + "\n")
    with pytest.raises(ModeselError, match="47 complete numeric rows") as err:
        read_elastodyn(main)
    assert err.value.file == str(blade) and err.value.field == "NBlInpSt"


def test_non_numeric_scalar(tmp_path):
    main = copy_deck(tmp_path)
    replace_line(main, "TowerHt", "tall")
    with pytest.raises(ModeselError, match="non-numeric") as err:
        read_elastodyn(main)
    assert err.value.file == str(main) and err.value.field == "TowerHt"


def test_non_numeric_table_value(tmp_path):
    main = copy_deck(tmp_path)
    tower = tmp_path / TOWER.name
    tower.write_text(tower.read_text().replace("3.9164100E+03", "heavy"))
    with pytest.raises(ModeselError) as err:
        read_elastodyn(main)
    assert err.value.file == str(tower) and err.value.field == "NTwInpSt"
    assert "heavy" in str(err.value)


def test_flag_must_be_boolean(tmp_path):
    main = copy_deck(tmp_path)
    replace_line(main, "TwFADOF1", "maybe")
    with pytest.raises(ModeselError) as err:
        read_elastodyn(main)
    assert err.value.field == "TwFADOF1"


def test_missing_required_input(tmp_path):
    main = copy_deck(tmp_path)
    main.write_text("\n".join(l for l in main.read_text().splitlines() if l.split()[1:2] != ["NacMass"]) + "\n")
    with pytest.raises(ModeselError) as err:
        read_elastodyn(main)
    assert err.value.file == str(main) and err.value.field == "NacMass"


def test_deck_without_outlist_end_is_read(tmp_path):
    """openfast_io loops forever on an OutList with no END line; the reader adds it."""
    import shutil
    from modesel.turbine.elastodyn import read_elastodyn
    src = "tests/data/openfast_free_decay/tower_fa_ss_shaft"
    for name in ("Spar_ED_ForED.dat", "NRELOffshrBsline5MW_Blade.dat",
                 "NRELOffshrBsline5MW_Offshore_ElastoDyn_Tower.dat"):
        shutil.copy(f"{src}/{name}", tmp_path / name)
    deck = tmp_path / "Spar_ED_ForED.dat"
    lines = [l for l in deck.read_text().splitlines() if not l.startswith("END")]
    deck.write_text("\n".join(lines) + "\n")
    turbine = read_elastodyn(deck)
    assert turbine.tower_base_height == 20.0
