"""Front functions of the simulator: `load_scene`, `build`, `simulate`,
`linearize_scene`, and what they return. They live in the modules of
`modesel/simulation/` named after what they hold:

- scene.py: `Scene`, `load_scene` (TOML or ElastoDyn/OpenFAST files);
- assembly.py: `Built`, `build` (equations and effects of a scene);
- equilibrium.py: `static_equilibrium`;
- stability.py: `check_static_stability` (refuse statically unstable scenes);
- transient.py: `simulate`, `divergence_bounds`; results.py: `SimulationResult`;
- modal.py: `linearize_scene`; coleman.py: multi-blade coordinates and whirl.

Output channels and their units: model/outputs.py (`channel_unit`).
"""
from modesel.model.outputs import channel_unit
from modesel.simulation.assembly import Built, build, effective_modeset
from modesel.simulation.coleman import MBC_AZIMUTHS
from modesel.simulation.equilibrium import static_equilibrium
from modesel.simulation.modal import linearize_scene
from modesel.simulation.results import SimulationResult
from modesel.simulation.scene import Scene, load_scene
from modesel.simulation.stability import STABILITY_NOISE, check_static_stability
from modesel.simulation.transient import divergence_bounds, simulate
from modesel.vocabulary import DRIVETRAIN_DOFS, RIGID_BODY_DOFS

__all__ = ["Built", "DRIVETRAIN_DOFS", "MBC_AZIMUTHS", "RIGID_BODY_DOFS", "STABILITY_NOISE", "Scene",
           "SimulationResult", "build", "channel_unit", "check_static_stability", "divergence_bounds",
           "effective_modeset", "linearize_scene", "load_scene", "simulate", "static_equilibrium"]
