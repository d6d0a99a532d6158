"""Reduced multibody simulation: turbine description, bodies, scenes, integration."""
