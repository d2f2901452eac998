"""The MuJoCo DeepRacer simulator: tracks, reward params, worlds, car and the Gymnasium environment.

`racer/DeepRacer-v0` is registered here with a string entry point, so importing this package does not import
MuJoCo; `gymnasium.make("racer/DeepRacer-v0", config=EnvConfig(...))` does.
"""

from gymnasium.envs.registration import register, registry

ENV_ID = "racer/DeepRacer-v0"

if ENV_ID not in registry:
    register(id=ENV_ID, entry_point="racer.shared.sim.env:DeepRacerEnv", disable_env_checker=False)

__all__ = ["ENV_ID"]
