"""Wire format of one episode: msgpack with raw, zstd-compressed numpy buffers. Never pickle.

Every episode a worker plays is sent on its own, as one Redis stream entry, as soon as it ends, so it arrives whole or
not at all and a worker that dies loses only the episodes it was playing. Layout (schema `racer.episodes/2`):

    {"schema": "racer.episodes/2",
     "iteration": int, "episode_number": int, "worker_id": int, "world": str, "policy_version": int,
     "episode_index": int, "final_status": str, "progress": float, "info": {str: scalar},
     "arrays": {"actions": ARRAY, "rewards": ARRAY, "log_probs": ARRAY, "obs/<SENSOR_NAME>": ARRAY, ...}}
    ARRAY = {"dtype": "<u1", "shape": [T, 120, 160, 1], "codec": "zstd" | "zlib" | "raw", "data": bytes}

`episode_number` is the episode's number within the iteration (0..E-1); `episode_index` the worker's running count
of training episodes (the simtrace `episode` column). Schema 1 wrapped episodes in a batch that always held one.

Done flags are not sent: every episode is complete, so its last transition is the only terminal one
(`episode_ends` in the trainer) and the trainer bootstraps with 0 after it, as DeepRacer does. `final_status`
says how it ended (lap_complete, off_track, ...). T is the episode's step count, the same for every array.

Camera frames are most of the bytes. Workers compress them with zstd level 1: on rendered grayscale frames it
shrinks them about as much as zlib level 1 at a fraction of the CPU time, and compressing runs in the worker's step
loop, once per finished episode (`python -m benchmarks rollout` measures it). That keeps a 20-episode iteration to a few MB
in Redis. Arrays with codec "zlib" still decode.
"""

from __future__ import annotations

import zlib

import msgpack
import numpy as np
import zstandard

from racer.shared.episode import Episode

SCHEMA = "racer.episodes/2"
_COMPRESS_MIN_BYTES = 4096
ZSTD_LEVEL = 1
_ALLOWED_DTYPES = {"|u1", "<u1", "<i8", "<f4", "<f8", "<i4", "|b1"}


class CodecError(ValueError):
    """A message that is not a valid `racer.episodes/2` episode."""


def _encode_array(array: np.ndarray) -> dict:
    array = np.ascontiguousarray(array)
    raw = array.tobytes()
    if len(raw) >= _COMPRESS_MIN_BYTES:
        data = zstandard.ZstdCompressor(level=ZSTD_LEVEL).compress(raw)
        return {"dtype": array.dtype.str, "shape": list(array.shape), "codec": "zstd", "data": data}
    return {"dtype": array.dtype.str, "shape": list(array.shape), "codec": "raw", "data": raw}


def _decode_array(spec: dict, where: str) -> np.ndarray:
    dtype = spec.get("dtype")
    if dtype not in _ALLOWED_DTYPES:
        raise CodecError(f"{where}: unsupported dtype {dtype!r}")
    data = spec["data"]
    shape = tuple(int(n) for n in spec["shape"])
    if spec.get("codec") == "zstd":
        expected_bytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
        try:
            data = zstandard.ZstdDecompressor().decompress(data, max_output_size=expected_bytes)
        except zstandard.ZstdError as error:
            raise CodecError(f"{where}: not a zstd frame of {expected_bytes} bytes: {error}") from error
    elif spec.get("codec") == "zlib":
        data = zlib.decompress(data)
    elif spec.get("codec") != "raw":
        raise CodecError(f"{where}: unknown codec {spec.get('codec')!r}")
    array = np.frombuffer(data, dtype=np.dtype(dtype))
    if array.size != int(np.prod(shape)):
        raise CodecError(f"{where}: {array.size} values do not fill shape {shape}")
    return array.reshape(shape)


def encode_episode(episode: Episode) -> bytes:
    episode.validate()
    arrays = {
        "actions": _encode_array(episode.actions),
        "rewards": _encode_array(episode.rewards.astype(np.float32, copy=False)),
        "log_probs": _encode_array(episode.log_probs.astype(np.float32, copy=False)),
    }
    for name, observation in episode.observations.items():
        arrays[f"obs/{name}"] = _encode_array(observation)
    message = {
        "schema": SCHEMA,
        "iteration": episode.iteration,
        "episode_number": episode.episode_number,
        "worker_id": episode.worker_id,
        "world": episode.world,
        "policy_version": episode.policy_version,
        "episode_index": episode.episode_index,
        "final_status": episode.final_status,
        "progress": float(episode.progress),
        "info": dict(episode.info),
        "arrays": arrays,
    }
    return msgpack.packb(message, use_bin_type=True)


def decode_episode(payload: bytes) -> Episode:
    try:
        message = msgpack.unpackb(payload, raw=False, strict_map_key=True)
    except (msgpack.ExtraData, msgpack.FormatError, msgpack.StackError, ValueError) as error:
        raise CodecError(f"episode is not valid msgpack: {error}") from error
    if not isinstance(message, dict) or message.get("schema") != SCHEMA:
        raise CodecError(
            f"expected schema {SCHEMA!r}, got {message.get('schema') if isinstance(message, dict) else type(message)}"
        )
    where = (
        f"episode {message.get('episode_number')} of iteration {message.get('iteration')} "
        f"from worker {message.get('worker_id')}"
    )
    try:
        arrays = {name: _decode_array(spec, f"{where} {name}") for name, spec in message["arrays"].items()}
        episode = Episode(
            observations={name.removeprefix("obs/"): a for name, a in arrays.items() if name.startswith("obs/")},
            actions=arrays["actions"],
            rewards=arrays["rewards"],
            log_probs=arrays["log_probs"],
            policy_version=int(message["policy_version"]),
            worker_id=int(message["worker_id"]),
            world=str(message["world"]),
            iteration=int(message["iteration"]),
            episode_number=int(message["episode_number"]),
            episode_index=int(message["episode_index"]),
            final_status=str(message["final_status"]),
            progress=float(message["progress"]),
            info=dict(message["info"]),
        )
    except KeyError as error:
        raise CodecError(f"{where}: field {error} is missing") from error
    try:
        episode.validate()
    except ValueError as error:
        raise CodecError(f"{where}: {error}") from error
    return episode
