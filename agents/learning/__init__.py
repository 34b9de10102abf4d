"""Learning: training policies with stable-baselines3 or RLlib, and the agents that run them.

Owns the imitation of the planner: the learned agents' observation (:mod:`.egomap`), the
training envs' wrappers with the teacher's labels (:mod:`.wrappers`), behaviour cloning and DAgger
(:mod:`.imitation`), PPO fine-tuning of their policies (:mod:`.finetune`) and the agent of its
policies (:mod:`.learned`); the SB3 training loop with its
curriculum (:mod:`.training`), the agent of a saved SB3 model (:mod:`.ppo`), results over training
seeds (:mod:`.seeds`), the RLlib backend, agent and connectors (:mod:`.rllib`) and the training
process's allocator setting (:mod:`.runtime`). torch is
imported here and nowhere else.

May import: :mod:`stereo_nav_env`, :mod:`agents.base`, :mod:`agents.planning` (the teacher, and
the planner's map as the learned agents' memory), :mod:`agents.evaluation`.
"""
