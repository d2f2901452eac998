import dataclasses

import msgpack
import numpy as np
import pytest

from racer.shared.episode import Episode
from racer.shared.transport.codec import CodecError, decode_episode, encode_episode


@pytest.mark.parametrize("continuous", [False, True])
def test_round_trip_is_exact(continuous, episode_factory):
    original = episode_factory(40, 1, continuous, worker_id=1, world="carpet", iteration=3, episode_number=5)
    copy = decode_episode(encode_episode(original))
    assert (copy.iteration, copy.episode_number, copy.worker_id, copy.world, copy.policy_version) == (
        3,
        5,
        1,
        "carpet",
        3,
    )
    for name in original.observations:
        assert copy.observations[name].dtype == original.observations[name].dtype
        np.testing.assert_array_equal(copy.observations[name], original.observations[name])
    np.testing.assert_array_equal(copy.actions, original.actions)
    assert copy.actions.dtype == original.actions.dtype
    np.testing.assert_array_equal(copy.rewards, original.rewards)
    np.testing.assert_array_equal(copy.log_probs, original.log_probs)
    assert (copy.final_status, copy.progress, copy.episode_index, copy.info) == (
        "off_track",
        12.5,
        original.episode_index,
        original.info,
    )


def test_images_are_compressed(episode_factory):
    episode = episode_factory(50, 3)
    raw_bytes = sum(a.nbytes for a in episode.observations.values())
    assert len(encode_episode(episode)) < raw_bytes


def test_rejects_foreign_messages():
    with pytest.raises(CodecError, match="schema"):
        decode_episode(msgpack.packb({"schema": "other"}))
    with pytest.raises(CodecError, match="schema"):
        decode_episode(msgpack.packb({"schema": "racer.episodes/1", "episodes": []}))  # the batches of schema 1
    with pytest.raises(CodecError, match="msgpack"):
        decode_episode(b"\xc1not msgpack")


def test_a_missing_field_is_a_codec_error_naming_it(episode_factory):
    message = msgpack.unpackb(encode_episode(episode_factory(5, 2, episode_number=4)), raw=False)
    del message["episode_number"]
    with pytest.raises(CodecError, match=r"iteration 3 from worker 1: field 'episode_number' is missing"):
        decode_episode(msgpack.packb(message, use_bin_type=True))


def test_rejects_mismatched_lengths(episode_factory):
    good = episode_factory(5, 4)
    bad = Episode(
        observations=good.observations,
        actions=good.actions[:3],
        rewards=good.rewards,
        log_probs=good.log_probs,
        policy_version=0,
        worker_id=0,
        world="base",
    )
    with pytest.raises(ValueError, match="actions has 3 steps"):
        encode_episode(bad)


def _recompress_with_zlib(payload: bytes) -> bytes:
    """The same episode as racer wrote it before zstd: every compressed array as zlib level 1."""
    import zlib

    import zstandard

    message = msgpack.unpackb(payload, raw=False)
    for spec in message["arrays"].values():
        if spec["codec"] == "zstd":
            spec["codec"] = "zlib"
            spec["data"] = zlib.compress(zstandard.ZstdDecompressor().decompress(spec["data"]), 1)
    return msgpack.packb(message, use_bin_type=True)


def test_frames_travel_as_zstd_and_zlib_arrays_still_decode(episode_factory):
    episode = episode_factory(30, 5)
    payload = encode_episode(episode)
    codecs = {name: spec["codec"] for name, spec in msgpack.unpackb(payload)["arrays"].items()}
    assert codecs["obs/FRONT_FACING_CAMERA"] == "zstd"
    old_style = decode_episode(_recompress_with_zlib(payload))
    np.testing.assert_array_equal(
        old_style.observations["FRONT_FACING_CAMERA"], episode.observations["FRONT_FACING_CAMERA"]
    )


def test_a_damaged_zstd_array_is_a_codec_error_naming_the_array(episode_factory):
    episode = dataclasses.replace(episode_factory(30, 6), iteration=4, episode_number=1)
    message = msgpack.unpackb(encode_episode(episode), raw=False)
    spec = message["arrays"]["obs/FRONT_FACING_CAMERA"]
    spec["data"] = spec["data"][: len(spec["data"]) // 2]
    with pytest.raises(
        CodecError, match=r"episode 1 of iteration 4 from worker 1 obs/FRONT_FACING_CAMERA: not a zstd frame"
    ):
        decode_episode(msgpack.packb(message, use_bin_type=True))
