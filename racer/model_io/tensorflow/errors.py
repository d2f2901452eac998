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
