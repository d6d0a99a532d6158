"""Scenes and the simulator's front functions (`load_scene`, `build`,
`simulate`, `linearize_scene`): see `modesel.simulation.api`. Importing the
package registers the OpenFAST deck reader (`fst`) with `scene.load_scene`."""
from modesel.simulation import fst  # noqa: F401
