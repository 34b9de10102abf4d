"""Evaluation: the seeded scene suite and the tools that measure the project.

Owns the evaluation suite with its rules, intervals and tables (:mod:`.suite`), the pairing of
two perceptions' runs (:mod:`.perception_cost`), the closed-loop ablation of the uncertainty model
across perceptions (:mod:`.ablation`, issue 43), the demo episode and its pictures
(:mod:`.demo`, :mod:`.drawing`), the stereo's accuracy against ground truth and OpenCV's SGBM
(:mod:`.stereo_accuracy`), the soak runs for leaks and hangs (:mod:`.soak`) and the step-by-step
traces of model-based agents' stalls and detours (:mod:`.stall`, issue 42) and of a learned
student beside its teacher (:mod:`.student`, issue 41).

May import: :mod:`modeling`, :mod:`stereo_nav_env` and the agents (through the registry).
"""
