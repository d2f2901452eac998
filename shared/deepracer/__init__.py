"""DeepRacer file schemas: model_metadata.json, hyperparameters.json, simtrace CSV, metrics JSON, training_params.yaml.

Each module reads the files the AWS SimApp, the console, DRoA and DeepRacer-for-Cloud produce (real files must parse)
and writes them byte-compatibly, so models, logs and analysis notebooks move between racer and DeepRacer unchanged.
Facts come from DeepRacer's source (docs/deepracer-sources.md); bad input raises a ValueError subclass naming the file
and the field.
"""
