"""stereo-nav's Gymnasium environments; importing this package registers their ids.

``StereoNav-v0``: continuous ``Box(-1, 1, (3,))`` actions (forward speed, turn rate, head pan
target); ``StereoNavDiscrete-v0``: ``Discrete(11)`` move-and-look macro actions. Both observe the
model of the stereo pair (situations, critical regions, a top-down raster); see
:class:`stereo_nav_env.env.StereoNavEnv`.
"""

from gymnasium.envs.registration import register

register(
    id="StereoNav-v0",
    entry_point="stereo_nav_env.env:StereoNavEnv",
    max_episode_steps=500,
)

register(
    id="StereoNavDiscrete-v0",
    entry_point="stereo_nav_env.env:StereoNavDiscreteEnv",
    max_episode_steps=500,
)
