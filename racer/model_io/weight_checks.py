"""The model's weights, checked for `validate.py`: racer's ONNX inference models (a valid graph whose output size
matches the action space), racer checkpoints against their manifests and the network the metadata asks for, and
the car bundle's contents."""

from __future__ import annotations

import io
import tarfile

from racer.model_io import checkpoints as ck
from racer.model_io.codes import ProblemCode
from racer.model_io.validation_run import CHECKPOINT_FIX, ValidationRun, decode_json
from racer.shared import model_layout
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.model_layout import MANIFEST_SUFFIX, CheckpointName

CAR_BUNDLE_KEY = model_layout.CAR_BUNDLE
CAR_BUNDLE_MODELS = ("agent/model.onnx", "agent/model.pb")


def check_inference_models(run: ValidationRun, keys: list[str], metadata: ModelMetadata | None) -> None:
    """This system's `model_<N>.onnx`: a valid ONNX graph whose output size matches the action space."""
    import onnx  # only needed when there is an ONNX file; keeps `racer model --help` fast
    from google.protobuf.message import DecodeError

    for key in keys:
        if not key.endswith(".onnx"):
            continue
        data = run.read(key)
        if data is None:
            continue
        try:
            graph = onnx.load_from_string(data)
            onnx.checker.check_model(graph)
        except (DecodeError, onnx.checker.ValidationError, ValueError) as error:
            run.add(
                ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
                key,
                f"is not a valid ONNX model: {error}",
                "restore the file from the training run (racer writes model_<N>.onnx with every checkpoint)",
            )
            continue
        if metadata is None or not graph.graph.output:
            continue
        dims = graph.graph.output[0].type.tensor_type.shape.dim
        width = dims[-1].dim_value if dims else 0
        if width and width != metadata.num_actions:
            run.add(
                ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
                key,
                f"outputs {width} values per observation but model_metadata.json's action space has "
                f"{metadata.num_actions}",
                "restore the model_metadata.json the model was trained with",
            )


def check_racer_checkpoints(
    run: ValidationRun, names: list[CheckpointName], metadata_key: str | None, metadata: ModelMetadata | None
) -> bool:
    """racer checkpoints carry a manifest with every file's size and sha256 and the network they were saved
    from: a file that doesn't match, or a model_metadata.json asking for another network, is an edited model.
    Returns True when the metadata disagrees with a checkpoint (the ONNX width check would repeat it)."""
    racer_names = [name for name in names if ck.is_racer_checkpoint(name, run.files)]
    if not racer_names:
        return False
    # torch comes with these imports; only models that hold racer checkpoints pay for it.
    from racer.shared.policy.manifest import CheckpointError, CheckpointInfo, sha256_hex
    from racer.shared.policy.networks import policy_config_from_metadata

    disagreeing: list[str] = []
    saved = None
    wanted_text = ""
    for name in racer_names:
        manifest_key = name.file(MANIFEST_SUFFIX)
        data = run.read(manifest_key)
        if data is None:
            continue
        try:
            info = CheckpointInfo.from_dict(decode_json(data, manifest_key))
        except (CheckpointError, ValueError, KeyError, TypeError) as error:
            run.add(
                ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
                manifest_key,
                f"is not a racer checkpoint manifest: {error}",
                "restore the file from the training run; racer writes it last, after the checkpoint's files",
            )
            continue
        for file_name, expected in sorted(info.files.items()):
            key = ck.MODEL_DIR + file_name
            if key not in run.files:
                run.add(
                    ProblemCode.CHECKPOINT_FILES_DOES_NOT_EXIST,
                    key,
                    f"listed by {manifest_key} but missing",
                    CHECKPOINT_FIX,
                )
                continue
            content = run.read(key)
            if content is None:
                continue
            if len(content) != expected.get("size_bytes") or sha256_hex(content) != expected.get("sha256"):
                run.add(
                    ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
                    key,
                    f"does not match the size and sha256 recorded in {manifest_key} (the file was changed)",
                    "restore the checkpoint files exactly as the trainer wrote them",
                )
        if metadata is not None:
            try:
                wanted = policy_config_from_metadata(
                    metadata,
                    info.policy_config.network,
                    info.policy_config.stack_size,  # not model_metadata's to say
                )
                wanted_text = f"{wanted.num_actions} {wanted.action_space_type} actions, {wanted.neural_network}"
            except ValueError as error:
                wanted, wanted_text = None, str(error)
            if wanted != info.policy_config:
                disagreeing.append(name.name)
                saved = info.policy_config
    if disagreeing and saved is not None:
        run.add(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            metadata_key or model_layout.MODEL_METADATA,
            f"asks for {wanted_text}, but checkpoint {', '.join(disagreeing)} was trained with "
            f"{saved.num_actions} {saved.action_space_type} actions, {saved.neural_network}",
            "restore the model_metadata.json the model was trained with (each racer checkpoint manifest "
            "model/<N>_Step-<M>.ckpt.json holds a copy under model_metadata)",
        )
    return bool(disagreeing)


def check_car_bundle(run: ValidationRun) -> None:
    if CAR_BUNDLE_KEY not in run.files:
        return
    data = run.read(CAR_BUNDLE_KEY)
    if data is None:
        return
    try:
        with tarfile.open(fileobj=io.BytesIO(data), mode="r:*") as bundle:
            names = {member.name.removeprefix("./") for member in bundle.getmembers() if member.isfile()}
    except (tarfile.TarError, EOFError, OSError) as error:
        run.add(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            CAR_BUNDLE_KEY,
            f"is not a readable tar.gz ({error})",
            "rebuild it with racer model export, or delete it (imports don't need it)",
        )
        return
    missing = ["model_metadata.json"] if "model_metadata.json" not in names else []
    if not names.intersection(CAR_BUNDLE_MODELS):
        missing.append(" or ".join(CAR_BUNDLE_MODELS))
    if missing:
        run.add(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            CAR_BUNDLE_KEY,
            f"lacks {', '.join(missing)}",
            "rebuild it with racer model export, or delete it (imports don't need it)",
        )
