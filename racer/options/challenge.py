"""The `--race-type` / `--race-param` options shared by `racer train`, `racer trainer`, `racer evaluate` and the bench."""

from __future__ import annotations

from collections.abc import Callable

import click

from racer.shared.sim.objects.challenge import CHALLENGE_KEYS, ChallengeConfig

RACE_TYPE_NAMES: dict[str, str] = {
    "time-trial": "TIME_TRIAL",
    "object-avoidance": "OBJECT_AVOIDANCE",
    "head-to-bot": "HEAD_TO_BOT",
}


def challenge_options(command: Callable) -> Callable:
    """Add --race-type and --race-param KEY=VALUE (repeatable) to a click command."""
    command = click.option(
        "--race-param",
        "race_param",
        multiple=True,
        metavar="KEY=VALUE",
        help="An obstacle / bot-car training_params key, e.g. NUMBER_OF_OBSTACLES=3, OBJECT_POSITIONS='0.2,1;0.5,-1', "
        "NUMBER_OF_BOT_CARS=2, BOT_CAR_SPEED=0.5, IS_LANE_CHANGE=True (repeatable; keys in README).",
    )(command)
    return click.option(
        "--race-type",
        type=click.Choice([*RACE_TYPE_NAMES, *RACE_TYPE_NAMES.values()], case_sensitive=False),
        default=None,
        help="RACE_TYPE for every worker (default: workers.json's, else time-trial).",
    )(command)


def challenge_params_from_options(race_type: str | None, race_param: tuple[str, ...]) -> tuple[tuple[str, str], ...]:
    """The options as training_params pairs, checked: an unknown key or a bad value names the option and key."""
    pairs: dict[str, str] = {}
    if race_type:
        pairs["RACE_TYPE"] = RACE_TYPE_NAMES.get(race_type.lower(), race_type.upper())
    for item in race_param:
        key, sep, value = item.partition("=")
        key = key.strip().upper()
        if not sep or key not in CHALLENGE_KEYS or key == "RACE_TYPE":
            raise click.BadParameter(
                f"{item!r}: expected KEY=VALUE with KEY one of {', '.join(k for k in CHALLENGE_KEYS if k != 'RACE_TYPE')}",
                param_hint="--race-param",
            )
        pairs[key] = value.strip()
    if pairs:
        try:
            ChallengeConfig.from_training_params(pairs)
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="--race-type/--race-param") from error
    return tuple(pairs.items())
