"""Errors of the TensorFlow conversions, importable without torch or TensorFlow (the CLI catches them)."""


class UnsupportedGraphError(ValueError):
    """A DeepRacer graph holds something racer's networks cannot represent; the message says exactly what."""


class CustomNetworkExportError(ValueError):
    """A model DeepRacer on AWS cannot import: your own network (network.json), or stacked frames."""


def custom_network_export_refusal(neural_network: str) -> str:
    return (
        f"cannot export for DeepRacer on AWS: the model's network {neural_network!r} is your own (network.json), "
        "and DeepRacer on AWS imports only its three built-in networks (DEEP_CONVOLUTIONAL_NETWORK_SHALLOW, "
        "DEEP_CONVOLUTIONAL_NETWORK, DEEP_CONVOLUTIONAL_NETWORK_DEEP); `racer model export` without --for droa "
        "writes its frozen graph for the car"
    )


def stacked_frames_export_refusal(stack_size: int) -> str:
    return (
        f"cannot export for DeepRacer on AWS: the model sees {stack_size} stacked camera frames (hyperparameters.json "
        f"stack_size), so its camera input takes {stack_size} times the channels; DeepRacer on AWS's import restores "
        "the checkpoint and feeds it single frames (its validation builds each sensor's input from "
        "model_metadata.json alone, and its training config has no stack_size), which such a graph cannot take; "
        "`racer model export` without --for droa writes its frozen graph for the car"
    )
