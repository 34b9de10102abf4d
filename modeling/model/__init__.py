"""Model: from a floor observation to the possible situations (Miura, ICRA-94, sections 2 and 4).

Owns the exact gap passability (:mod:`.gaps`), the relations between uncertain segments
(:mod:`.relations`), the items that enter the model (:mod:`.items`), obstacles with their
polygons (:mod:`.obstacles`), critical regions and situations (:mod:`.situations`,
:mod:`.partitions`), the ambiguous units that move together (:mod:`.ambiguity`), the occluded
area (:mod:`.occlusion`), the result records (:mod:`.records`), the path graph of a situation
(:mod:`.topology`) and the orchestration of them all, :func:`~modeling.model.build.build_model`
(:mod:`.build`).

May import: numpy, scipy, shapely, networkx, Numba, :mod:`modeling.observation` and the shared
helpers at the top of :mod:`modeling`. Never :mod:`modeling.stereo` or :mod:`modeling.memory`.
Its compiled loops live in the private ``_kernels`` subpackage beside the readable references.
"""
