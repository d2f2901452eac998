"""The set-ups of `racer bench time-to-lap --race-type` (issue 13): race params, and the training recipe each race's
benchmark uses. The recipes are the benchmark's choices, not racer's defaults for users (README, "Benchmarks")."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TimeToLapRace:
    race_params: tuple[tuple[str, str], ...] = ()
    """RACE_TYPE and the obstacle / bot-car training_params keys for every worker."""
    reward_function: str = "awsdoc_example_1.py"
    """File name in ../shared/deepracer-data/reward_functions (used when --reward-function is not given)."""
    hyperparameters: tuple[tuple[str, int | float], ...] = ()
    """hyperparameters.json keys of the clipped-PPO recipe; the SimApp's defaults for the rest (and for SAC)."""


OBJECT_AVOIDANCE_REWARD = "dpr401_object_avoidance_head_to_head.py"
OBJECT_AVOIDANCE_RECIPE: tuple[tuple[str, int | float], ...] = (("num_epochs", 3), ("discount_factor", 0.99))
"""Clipped PPO against boxes (README, "Benchmarks"): the update is most of the CPU on two cores, so 3 epochs (the
console's lowest); a 100-step horizon, since the reward pays for surviving; DeepRacer's learning rate (0.0003): at
0.001 the greedy policy reached 2 of 3 laps in 6 minutes and never 3 of 3 in 30."""
HEAD_TO_BOT_RECIPE: tuple[tuple[str, int | float], ...] = (*OBJECT_AVOIDANCE_RECIPE, ("lr", 0.001))
"""The same at the console's highest learning rate, with which the head-to-bot benchmark was measured."""

TIME_TO_LAP_RACES: dict[str, TimeToLapRace] = {
    "time-trial": TimeToLapRace(),
    "object-avoidance": TimeToLapRace(
        race_params=(("RACE_TYPE", "OBJECT_AVOIDANCE"), ("OBJECT_POSITIONS", "0.23,-1;0.46,1;0.67,-1")),
        reward_function=OBJECT_AVOIDANCE_REWARD,
        hyperparameters=OBJECT_AVOIDANCE_RECIPE,
    ),
    "head-to-bot": TimeToLapRace(
        race_params=(
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
    """hyperparameters.json of a benchmark run: DeepRacer's 20 episodes per iteration, the race's PPO recipe, then
    --episodes-per-iteration when given."""
    recipe = dict(TIME_TO_LAP_RACES[race_type].hyperparameters) if algorithm == "clipped_ppo" else {}
    hyperparameters = {"num_episodes_between_training": 20, **recipe}
    if episodes_per_iteration is not None:
        hyperparameters["num_episodes_between_training"] = episodes_per_iteration
    return hyperparameters
