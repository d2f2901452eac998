"""Errors of the TensorFlow conversions, importable without torch or TensorFlow (the CLI catches them)."""


class UnsupportedGraphError(ValueError):
    """A DeepRacer graph holds something racer's networks cannot represent; the message says exactly what."""


class CustomNetworkExportError(ValueError):
    """A model with your own network (network.json): DeepRacer's TensorFlow files cannot be written for it yet, and
    DeepRacer on AWS imports only its three built-in networks."""


def custom_network_export_refusal(neural_network: str, layout: str) -> str:
    if layout == "droa":
        return (
            f"cannot export for DeepRacer on AWS: the model's network {neural_network!r} is your own (network.json), "
            "and DeepRacer on AWS imports only its three built-in networks (DEEP_CONVOLUTIONAL_NETWORK_SHALLOW, "
            "DEEP_CONVOLUTIONAL_NETWORK, DEEP_CONVOLUTIONAL_NETWORK_DEEP)"
        )
    return (
        f"cannot export: the model's network {neural_network!r} is your own (network.json), and racer cannot write "
        "its TensorFlow frozen graph for the car yet (the graph writer knows DeepRacer's three networks only); "
        "train, evaluate and race it in racer, or train one of DeepRacer's networks to reach the car"
    )


def stacked_frames_export_refusal(stack_size: int, layout: str) -> str:
    if layout == "droa":
        return (
            f"cannot export for DeepRacer on AWS: the model sees {stack_size} stacked frames (hyperparameters.json "
            "stack_size), and DeepRacer on AWS trains and imports single-frame models only"
        )
    return (
        f"cannot export: the model sees {stack_size} stacked camera frames (hyperparameters.json stack_size), and "
        "racer's TensorFlow frozen graph for a stacked input is not yet proven against the car's runtimes; train, "
        "evaluate and race it in racer, or train with stack_size 1 to reach the car"
    )
