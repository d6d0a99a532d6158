"""Scenes and the simulator's front functions (`load_scene`, `build`,
`simulate`, `linearize_scene`): see `modesel.simulation.api`."""
