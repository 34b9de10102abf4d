"""Simulation: the true world the robot moves in.

Owns the pymunk floor world and the robot body with its panning head (:mod:`.world`, the only
pymunk importer), the geodesic distance through the true free space (:mod:`.geodesic`) and the
scenes: their types, furniture parts, the map format and the generator (:mod:`.scenes`),
and head poses to measure perception on (:mod:`.views`).

May import: numpy, scipy, shapely, pymunk, :mod:`modeling` (the rig and the validators). Never
the perception, observation or rendering subpackages.
"""
