"""Rendering: pictures of the world, for the stereo camera and for people.

Owns the pyrender stereo renderer (:mod:`.renderer`, the only pyrender importer), the baked
shading of faces that both the renderer and the surrogate use (:mod:`.shading`) and the
top-down viewer of ``env.render()`` (:mod:`.viewer`).

May import: :mod:`modeling`, :mod:`stereo_nav_env.sim`. Never the perception or observation.
"""
