"""The surrogate perception: a floor observation from the true scene, no rendering (issue 17).

Owns what is visible from the head (:mod:`.visibility`), the floor segments of visible edges
with the stereo's error model (:mod:`.floor`), the grey levels beside each edge that the
matcher compares (:mod:`.photometry`), the detection and false-match rates with their calibration
against the stereo pipeline (:mod:`.rates`, :mod:`.calibration`) and the sensor that chains them
(:mod:`.sensor`). Its compiled loops live in the private ``_kernels`` subpackage.

May import: :mod:`modeling`, :mod:`stereo_nav_env.sim`, :mod:`stereo_nav_env.rendering.shading`
and the perception base.
"""
