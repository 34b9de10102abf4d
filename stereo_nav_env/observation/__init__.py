"""Observation: what the policy receives, packed from the models into the Dict space.

Owns the spaces and the packing of each observation mode (:mod:`.packing`), the egocentric
top-down raster of a model (:mod:`.raster`) and the record of the floor seen in the episode
(:mod:`.seen`).

May import: :mod:`modeling` and the environment's :mod:`stereo_nav_env.config`. Never the
simulator, the perception or the renderer.
"""
