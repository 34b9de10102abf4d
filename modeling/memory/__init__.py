"""Memory: the world-frame fusion of floor observations over an episode (paper section 6).

"Memory" in this project means this and only this: a :class:`~modeling.memory.fusion.ModelMemory`
of remembered floor segments, fused across views (:mod:`.fusion`), associated by a chi-square
gate (:mod:`.association`), with ambiguous candidates re-weighted by each view
(:mod:`.ambiguity`), the floor seen free against remembered segments (:mod:`.visibility`) and
its options (:mod:`.options`). :func:`~modeling.memory.fusion.build_memory_model` gives its
:class:`~modeling.model.records.EnvironmentModel`.

May import: numpy, scipy, shapely, Numba, :mod:`modeling.observation`, :mod:`modeling.model`
(the model of the memory is built by it) and the shared helpers at the top of :mod:`modeling`.
Never :mod:`modeling.stereo`. Its compiled loops live in the private ``_kernels`` subpackage.
"""
