"""Planning: the model-based agents ``greedy``, ``cautious`` and ``planner``.

Owns the agent that ties them together (:mod:`.navigator`), their parameters (:mod:`.config`),
the occupancy grid map built from the agent's own views (:mod:`.gridmap`), its cost map
(:mod:`.costmap`), the expected-cost planner (:mod:`.planner`, after Miura and Shirai, ICRA-92),
where to look (:mod:`.looking`, :mod:`.decision`), the route follower (:mod:`.follower`), bump
recovery (:mod:`.recovery`) and routes on known outlines (:mod:`.routes`).

May import: :mod:`modeling`, :mod:`stereo_nav_env.config` and :mod:`agents.base`. Never the
learning or evaluation subpackages.
"""
