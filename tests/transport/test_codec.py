import msgpack
import numpy as np
import pytest

from racer.shared.episode import Episode
from racer.shared.transport.codec import CodecError, EpisodeBatch, decode_batch, encode_batch


@pytest.mark.parametrize("continuous", [False, True])
def test_round_trip_is_exact(continuous, episode_factory):
    make_episode = episode_factory
    batch = EpisodeBatch(
        iteration=3,
        share=1,
        worker_id=1,
        world="carpet",
        policy_version=3,
        episodes=(make_episode(40, 1, continuous), make_episode(7, 2, continuous)),
    )
    decoded = decode_batch(encode_batch(batch))
    assert (decoded.iteration, decoded.share, decoded.worker_id, decoded.world) == (3, 1, 1, "carpet")
    for original, copy in zip(batch.episodes, decoded.episodes, strict=True):
        for name in original.observations:
            assert copy.observations[name].dtype == original.observations[name].dtype
            np.testing.assert_array_equal(copy.observations[name], original.observations[name])
        np.testing.assert_array_equal(copy.actions, original.actions)
        assert copy.actions.dtype == original.actions.dtype
        np.testing.assert_array_equal(copy.rewards, original.rewards)
        np.testing.assert_array_equal(copy.log_probs, original.log_probs)
        assert (copy.final_status, copy.progress, copy.episode_index) == ("off_track", 12.5, original.episode_index)


def test_images_are_compressed(episode_factory):
    make_episode = episode_factory
    batch = EpisodeBatch(0, 0, 0, "base", 0, (make_episode(50, 3),))
    raw_bytes = sum(a.nbytes for a in batch.episodes[0].observations.values())
    assert len(encode_batch(batch)) < raw_bytes


def test_rejects_foreign_messages():
    with pytest.raises(CodecError, match="schema"):
        decode_batch(msgpack.packb({"schema": "other"}))
    with pytest.raises(CodecError, match="msgpack"):
        decode_batch(b"\xc1not msgpack")


def test_rejects_mismatched_lengths(episode_factory):
    make_episode = episode_factory
    good = make_episode(5, 4)
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
        encode_batch(EpisodeBatch(0, 0, 0, "base", 0, (bad,)))


def _recompress_with_zlib(payload: bytes) -> bytes:
    """The same batch as racer wrote it before zstd: every compressed array as zlib level 1."""
    import zlib

    import zstandard

    message = msgpack.unpackb(payload, raw=False)
    for episode in message["episodes"]:
        for spec in episode["arrays"].values():
            if spec["codec"] == "zstd":
                spec["codec"] = "zlib"
                spec["data"] = zlib.compress(zstandard.ZstdDecompressor().decompress(spec["data"]), 1)
    return msgpack.packb(message, use_bin_type=True)


def test_frames_travel_as_zstd_and_zlib_batches_still_decode(episode_factory):
    episode = episode_factory(30, 5)
    payload = encode_batch(EpisodeBatch(2, 0, 0, "base", 2, (episode,)))
    codecs = {name: spec["codec"] for name, spec in msgpack.unpackb(payload)["episodes"][0]["arrays"].items()}
    assert codecs["obs/FRONT_FACING_CAMERA"] == "zstd"
    old_style = decode_batch(_recompress_with_zlib(payload)).episodes[0]
    np.testing.assert_array_equal(
        old_style.observations["FRONT_FACING_CAMERA"], episode.observations["FRONT_FACING_CAMERA"]
    )


def test_a_damaged_zstd_array_is_a_codec_error_naming_the_array(episode_factory):
    message = msgpack.unpackb(encode_batch(EpisodeBatch(4, 1, 1, "base", 4, (episode_factory(30, 6),))), raw=False)
    spec = message["episodes"][0]["arrays"]["obs/FRONT_FACING_CAMERA"]
    spec["data"] = spec["data"][: len(spec["data"]) // 2]
    with pytest.raises(CodecError, match=r"worker=1 iteration=4 episode #0 obs/FRONT_FACING_CAMERA: not a zstd frame"):
        decode_batch(msgpack.packb(message, use_bin_type=True))
