"""stereo-nav's Gymnasium environments; importing this package registers their ids.

``StereoNav-v0``: continuous ``Box(-1, 1, (3,))`` actions (forward speed, turn rate, head pan
target); ``StereoNavDiscrete-v0``: ``Discrete(11)`` move-and-look macro actions. Both observe the
model of the stereo pair (situations, critical regions, a top-down raster); see
:class:`stereo_nav_env.env.StereoNavEnv`. ``StereoNav-v1`` and ``StereoNavDiscrete-v1`` are the
same environments under the v1 episode rules (``rules="v1"``: collisions do not end an episode;
:data:`stereo_nav_env.config.RULES`) with the observation made for learned policies
(``observation_mode="policy"``).

The package: :mod:`.env` (the environment, a thin orchestrator), :mod:`.config` (its frozen
configurations), :mod:`.actions`, :mod:`.rewards` (named components), :mod:`.diagnostics` (the
models against ground truth), :mod:`.fusion` (the env's side of the fused memory), and the
subpackages :mod:`stereo_nav_env.sim` (the pymunk world and the scenes),
:mod:`stereo_nav_env.perception` (one interface: stereo, surrogate),
:mod:`stereo_nav_env.observation` (packing the Dict observation) and
:mod:`stereo_nav_env.rendering` (pyrender, shading, the viewer).
"""

from gymnasium.envs.registration import register

for _name, _entry in (("StereoNav", "StereoNavEnv"), ("StereoNavDiscrete", "StereoNavDiscreteEnv")):
    register(
        id=f"{_name}-v0",
        entry_point=f"stereo_nav_env.env:{_entry}",
        max_episode_steps=500,
    )
    register(
        id=f"{_name}-v1",
        entry_point=f"stereo_nav_env.env:{_entry}",
        max_episode_steps=500,
        kwargs={"rules": "v1", "observation_mode": "policy"},
    )
