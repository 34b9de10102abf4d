"""Stereo: from a rectified image pair to a floor observation (Miura, ICRA-94, section 3).

Owns the stereo rig and head pose (:mod:`.rig`), line segments and their edge points
(:mod:`.segments`, :mod:`.edge_points`), segment matching with local disparity histograms
(:mod:`.matching`, :mod:`.disparity_histograms`, Eq. 1), triangulation with endpoint covariances
projected to the floor (:mod:`.triangulation`), the floor segments of plain faces and of ground
lines (:mod:`.faces`, :mod:`.ground_lines`), and the chain of them all (:mod:`.pipeline`).

May import: numpy, scipy, OpenCV, Numba, :mod:`modeling.observation` (its output, the one seam
with :mod:`modeling.model`) and the shared helpers at the top of :mod:`modeling`. Never
:mod:`modeling.model` or :mod:`modeling.memory`. Its compiled loops live in the private
``_kernels`` subpackage beside the readable references.
"""
