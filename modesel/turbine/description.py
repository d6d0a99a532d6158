"""`Turbine`: everything the reduced model needs about a wind turbine.

Filled from an OpenFAST ElastoDyn deck by `modesel.turbine.elastodyn.read_elastodyn`
(or the built-in name `nrel5mw`). SI units, angles in rad, speeds in rad/s.
Axes follow ElastoDyn: x downwind, y to the left looking downwind, z up.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from modesel.turbine.beam import BeamProperties


@dataclass
class Turbine:
    """A wind turbine as the reduced multibody model sees it.

    Geometry [m]: `tower_height` (TowerHt, tower top above ground/MSL),
    `tower_base_height` (TowerBsHt), `tip_radius`, `hub_radius`, `overhang`
    (OverHang, negative upwind: from the yaw axis to the rotor apex, or to the
    teeter pin of a two-bladed rotor), `undersling` (UndSling, two-bladed rotors:
    from the teeter pin to the apex, along the shaft; `apex_overhang` is
    OverHang - UndSling), `shaft_gage` (ShftGagL: from the apex or teeter pin
    to the shaft's strain gauges, positive upwind), `twr2shft` (Twr2Shft), `nacelle_cm`
    (NacCMxn, NacCMyn, NacCMzn), `nacelle_imu` (NcIMUxn, NcIMUyn, NcIMUzn: the
    nacelle IMU from the tower top in the nacelle frame, 0 where the deck has
    none), `hub_cm` (HubCM).
    Angles [rad]: `precone` (PreCone, per blade), `shaft_tilt` (ShftTilt).
    Masses [kg] and inertias [kg m^2]: `hub_mass`, `hub_inertia` (about the
    shaft), `hub_teeter_inertia` (two-bladed rotors: about the teeter axis
    through the hub's CM, ElastoDyn's Hubf2Iner; 0 otherwise), `generator_inertia` (GenIner, about the HSS), `nacelle_mass`,
    `nacelle_yaw_inertia`, `yaw_bearing_mass`, `tip_mass` (per blade),
    `platform_mass`, `platform_inertia` (roll, pitch, yaw), `platform_cm`.
    Drivetrain: `gearbox_ratio`, `gearbox_efficiency` (fraction),
    `drivetrain_stiffness` [N m/rad], `drivetrain_damping` [N m s/rad].
    `gravity` [m/s^2].
    `elastodyn_shapes`: {field: [coefficients of x^2..x^6 per mode]} from the
    deck (tower_fa: 2 modes, tower_ss: 2, blade_flap: 2, blade_edge: 1).
    `dofs`: ElastoDyn DOF flags by name (TwFADOF1, GenDOF, ...).
    `initial`: ElastoDyn initial conditions in SI (TTDspFA [m], RotSpeed
    [rad/s], Azimuth [rad]: blade 1's, 0 when it points up, BlPitch [rad]
    per blade, ...).
    `azimuth_b1_up` [rad]: ElastoDyn's AzimB1Up, the azimuth its input and
    output Azimuth (LSSTipPxa, LSSGagPxa) read when blade 1 points up.
    `source`: path of the main file it came from.
    """

    tower: BeamProperties
    blade: BeamProperties
    num_blades: int = 3
    tower_height: float = 87.6
    tower_base_height: float = 0.0
    tip_radius: float = 63.0
    hub_radius: float = 1.5
    precone: tuple = (0.0, 0.0, 0.0)
    shaft_tilt: float = 0.0
    overhang: float = 0.0
    twr2shft: float = 0.0
    nacelle_cm: tuple = (0.0, 0.0, 0.0)
    nacelle_imu: tuple = (0.0, 0.0, 0.0)
    hub_cm: float = 0.0
    hub_mass: float = 0.0
    hub_inertia: float = 0.0
    hub_teeter_inertia: float = 0.0
    undersling: float = 0.0
    #: a two-bladed rotor's delta-3 angle [rad] (Delta3): the blades turned by it about the shaft
    delta3: float = 0.0
    shaft_gage: float = 0.0
    generator_inertia: float = 0.0
    nacelle_mass: float = 0.0
    nacelle_yaw_inertia: float = 0.0
    yaw_bearing_mass: float = 0.0
    tip_mass: tuple = (0.0, 0.0, 0.0)
    platform_mass: float = 0.0
    platform_inertia: tuple = (0.0, 0.0, 0.0)
    platform_cm: tuple = (0.0, 0.0, 0.0)
    platform_ref_z: float = 0.0
    gearbox_ratio: float = 1.0
    gearbox_efficiency: float = 1.0
    azimuth_b1_up: float = 0.0
    drivetrain_stiffness: float = 0.0
    drivetrain_damping: float = 0.0
    gravity: float = 9.80665
    elastodyn_shapes: dict = field(default_factory=dict)
    dofs: dict = field(default_factory=dict)
    initial: dict = field(default_factory=dict)
    source: str | None = None
    notes: tuple = ()
    #: ElastoDyn's analysis nodes per blade / tower (BldNodes, TwrNodes), None if unknown
    blade_nodes: int | None = None
    tower_nodes: int | None = None
    #: ElastoDyn's blade nodes (1-based) with strain gauges (BldGagNd, NBlGages of them)
    blade_gauges: tuple = ()
    #: ElastoDyn's tower nodes (1-based) with strain gauges (TwrGagNd, NTwGages of them)
    tower_gauges: tuple = ()

    @property
    def apex_overhang(self) -> float:
        """Distance from the yaw axis to the rotor apex along the shaft [m]
        (ElastoDyn: rPQ = -UndSling g1 from the teeter pin at OverHang)."""
        return self.overhang - self.undersling
