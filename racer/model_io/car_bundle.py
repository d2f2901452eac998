"""The car bundle `model.tar.gz`: model_metadata.json and the inference model, byte-reproducible.

DeepRacer's bundle holds the TensorFlow graph at `agent/model.pb` (deepracer-simapp v5.3.3
`bundle/markov/training_worker.py`); racer's inference model is ONNX, so it goes to `agent/model.onnx`, the same
folder a car-side loader already opens, with the extension telling it which runtime to use.
"""

from __future__ import annotations

import gzip
import io
import tarfile

from racer.model_io import checkpoints as ck
from racer.model_io.problems import ImportPlan
from racer.shared.model_layout import CheckpointName

CAR_BUNDLE_ONNX = "agent/model.onnx"
CAR_BUNDLE_PB = "agent/model.pb"


def car_bundle_member(inference_key: str) -> str:
    """Where an inference model goes in the bundle: agent/model.onnx or agent/model.pb."""
    return CAR_BUNDLE_ONNX if inference_key.endswith(".onnx") else CAR_BUNDLE_PB


def car_bundle(metadata: bytes, inference_key: str, inference_model: bytes) -> tuple[bytes, str]:
    """`model.tar.gz` for the car: model_metadata.json + agent/model.onnx (or .pb). Byte-reproducible."""
    member = car_bundle_member(inference_key)
    buffer = io.BytesIO()
    # gzip stamps the time into its header unless told otherwise; 0 keeps the bytes reproducible.
    with (
        gzip.GzipFile(fileobj=buffer, mode="wb", mtime=0) as compressed,
        tarfile.open(fileobj=compressed, mode="w", format=tarfile.PAX_FORMAT) as bundle,
    ):
        for name, data in (("model_metadata.json", metadata), (member, inference_model)):
            info = tarfile.TarInfo(name)
            info.size = len(data)
            info.mode = 0o644
            info.mtime = 0
            bundle.addfile(info, io.BytesIO(data))
    return buffer.getvalue(), member


def car_inference_model(plan: ImportPlan, extra_files: dict[str, bytes], prefer_pb: bool) -> str | None:
    """The best checkpoint's inference model for the car bundle: the TensorFlow frozen graph when asked for (what
    every DeepRacer car software loads) or when it is the only one, else racer's ONNX."""
    best = CheckpointName.parse(plan.selection.best)
    assert best is not None  # validation accepted it
    candidates = ck.inference_model_files(best, {*plan.checkpoint_files, *extra_files})
    wanted = ".pb" if prefer_pb else ".onnx"
    return next((key for key in candidates if key.endswith(wanted)), candidates[0] if candidates else None)
