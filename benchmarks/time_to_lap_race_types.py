"""The set-ups of `python -m benchmarks time-to-lap --race-type` (issue 13): race params, and the training recipe
each race type's benchmark uses. The recipes are the benchmark's choices, not racer's defaults for users (README, "Benchmarks")."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class RaceTypeSetup:
    challenge_params: tuple[tuple[str, str], ...] = ()
    """RACE_TYPE and the obstacle / bot-car training_params keys for every worker."""
    reward_function: str = "awsdoc_example_1.py"
    """File name in reward_functions/ of the bench's --data folder (used when --reward-function is not given)."""
    hyperparameters: tuple[tuple[str, int | float], ...] = ()
    """hyperparameters.json keys of the clipped-PPO recipe; the SimApp's defaults for the rest (and for SAC)."""


OBJECT_AVOIDANCE_REWARD = "dpr401_object_avoidance_head_to_head.py"
PPO_RECIPE: tuple[tuple[str, int | float], ...] = (("num_epochs", 3), ("discount_factor", 0.99))
"""Clipped PPO on two CPU cores (README, "Benchmarks"): the update is most of the CPU, so 3 epochs (the console's
lowest) instead of 10; a 100-step horizon (discount 0.99), since both the centre-line and the object-avoidance rewards
pay for every step on the road; DeepRacer's learning rate (0.0003). In the time trial on a 2-core AVX2 machine
(2026-11-24) the SimApp's defaults had no lap in 6.8 minutes (best 83.5 %) where this recipe lapped 3 of 3 in 2.3;
against boxes 0.001 reached 2 of 3 laps in 6 minutes and never 3 of 3 in 30."""
HEAD_TO_BOT_RECIPE: tuple[tuple[str, int | float], ...] = (*PPO_RECIPE, ("lr", 0.001))
"""The same at the console's highest learning rate, with which the head-to-bot benchmark was measured."""

RACE_TYPE_SETUPS: dict[str, RaceTypeSetup] = {
    "time-trial": RaceTypeSetup(hyperparameters=PPO_RECIPE),
    "object-avoidance": RaceTypeSetup(
        challenge_params=(("RACE_TYPE", "OBJECT_AVOIDANCE"), ("OBJECT_POSITIONS", "0.23,-1;0.46,1;0.67,-1")),
        reward_function=OBJECT_AVOIDANCE_REWARD,
        hyperparameters=PPO_RECIPE,
    ),
    "head-to-bot": RaceTypeSetup(
        challenge_params=(
            ("RACE_TYPE", "HEAD_TO_BOT"),
            ("NUMBER_OF_BOT_CARS", "2"),
            ("BOT_CAR_SPEED", "0.5"),
            ("IS_LANE_CHANGE", "True"),
        ),
        reward_function=OBJECT_AVOIDANCE_REWARD,
        hyperparameters=HEAD_TO_BOT_RECIPE,
    ),
}
"""DeepRacer-for-Cloud's example obstacle positions; bots at 0.5 m/s changing lanes."""


def time_to_lap_hyperparameters(race_type: str, algorithm: str, episodes_per_iteration: int | None) -> dict:
    """hyperparameters.json of a benchmark run: DeepRacer's 20 episodes per iteration, the race type's PPO recipe, then
    --episodes-per-iteration when given."""
    recipe = dict(RACE_TYPE_SETUPS[race_type].hyperparameters) if algorithm == "clipped_ppo" else {}
    hyperparameters = {"num_episodes_between_training": 20, **recipe}
    if episodes_per_iteration is not None:
        hyperparameters["num_episodes_between_training"] = episodes_per_iteration
    return hyperparameters
