"""The Redis keys of one training run and the operations the trainer and the workers perform on them.

Keys (all under `racer:<run>:`, `<run>` = the model prefix):

| key | type | written by | meaning |
|---|---|---|---|
| `control` | stream | trainer | announcements: `iteration` (checkpoint k is ready, play it), `replay` (worker r: also play share j), `finished` |
| `episodes` | stream, consumer group `trainer` | workers | one entry per (iteration, share): an `EpisodeBatch` (codec.py) |
| `received:<k>` | set | trainer | shares of iteration k the trainer already holds (a restarted worker skips these) |
| `heartbeat:<worker>` | string with TTL | workers | JSON status (state, iteration, episodes, steps/s); absent = dead |
| `evaluations` | stream | worker 0 | greedy evaluation results per checkpoint |
| `iterations` | stream | trainer | per-iteration training summary (for progress displays and benchmarks) |
| `watching`, `frame:<worker>` | strings with TTL | viewer, workers | live camera frames for `racer view` (frames.py) |

Why streams: unlike DeepRacer's pub/sub, a stream entry waits until it is read, so nothing is lost when
a reader is busy or restarting; the consumer group keeps unacknowledged batches for a restarted trainer.
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass

import redis

from racer.shared.redis_connection import RedisLink
from racer.shared.transport.codec import CodecError, EpisodeBatch, decode_batch, encode_batch

log = logging.getLogger(__name__)

TRAINER_GROUP = "trainer"
HEARTBEAT_TTL_S = 15
STREAM_MAX_ENTRIES = 10_000


@dataclass(frozen=True)
class Announcement:
    """One entry of the control stream."""

    stream_id: str
    kind: str  # "iteration" | "replay" | "finished"
    iteration: int
    checkpoint: str = ""
    episodes_per_iteration: int = 0
    num_workers: int = 0
    share: int = -1
    target_worker: int = -1


@dataclass(frozen=True)
class ReceivedBatch:
    stream_id: str
    batch: EpisodeBatch


def share_sizes(episodes_per_iteration: int, num_workers: int) -> list[int]:
    """DeepRacer's split: worker i of W plays floor(E/W) episodes, one more if i < E mod W."""
    base, extra = divmod(episodes_per_iteration, num_workers)
    return [base + (1 if i < extra else 0) for i in range(num_workers)]


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


class RunChannel:
    """All Redis traffic of one run goes through here (workers and trainer alike)."""

    def __init__(self, link: RedisLink, run_id: str):
        self.link = link
        self.run_id = run_id
        self.prefix = f"racer:{run_id}:"

    def key(self, name: str) -> str:
        return self.prefix + name

    # ---- control stream -------------------------------------------------------------------------
    def announce_iteration(
        self, iteration: int, checkpoint: str, episodes_per_iteration: int, num_workers: int
    ) -> None:
        fields = {
            "kind": "iteration",
            "iteration": iteration,
            "checkpoint": checkpoint,
            "episodes_per_iteration": episodes_per_iteration,
            "num_workers": num_workers,
        }
        self.link.do(lambda r: r.xadd(self.key("control"), fields, maxlen=STREAM_MAX_ENTRIES, approximate=True))

    def request_replay(self, iteration: int, share: int, target_worker: int) -> None:
        fields = {"kind": "replay", "iteration": iteration, "share": share, "target_worker": target_worker}
        self.link.do(lambda r: r.xadd(self.key("control"), fields, maxlen=STREAM_MAX_ENTRIES, approximate=True))

    def announce_finished(self, iteration: int) -> None:
        fields = {"kind": "finished", "iteration": iteration}
        self.link.do(lambda r: r.xadd(self.key("control"), fields, maxlen=STREAM_MAX_ENTRIES, approximate=True))

    @staticmethod
    def _announcement(stream_id, fields) -> Announcement:
        f = {_text(k): _text(v) for k, v in fields.items()}
        return Announcement(
            stream_id=_text(stream_id),
            kind=f["kind"],
            iteration=int(f["iteration"]),
            checkpoint=f.get("checkpoint", ""),
            episodes_per_iteration=int(f.get("episodes_per_iteration", 0)),
            num_workers=int(f.get("num_workers", 0)),
            share=int(f.get("share", -1)),
            target_worker=int(f.get("target_worker", -1)),
        )

    def latest_iteration_announcement(self) -> Announcement | None:
        """The newest `iteration` or `finished` announcement (where a starting worker joins the run)."""
        entries = self.link.do(lambda r: r.xrevrange(self.key("control"), count=200))
        for stream_id, fields in entries:
            announcement = self._announcement(stream_id, fields)
            if announcement.kind in {"iteration", "finished"}:
                return announcement
        return None

    def next_announcements(self, after_id: str, block_s: float) -> list[Announcement]:
        """Announcements after `after_id`, blocking up to `block_s` (no busy polling)."""
        result = self.link.do(
            lambda r: r.xread({self.key("control"): after_id}, count=100, block=max(1, int(block_s * 1000)))
        )
        announcements = []
        for _stream, entries in result or []:
            announcements += [self._announcement(stream_id, fields) for stream_id, fields in entries]
        return announcements

    # ---- episode stream -------------------------------------------------------------------------
    def push_batch(self, batch: EpisodeBatch) -> None:
        payload = encode_batch(batch)
        fields = {"iteration": batch.iteration, "share": batch.share, "worker_id": batch.worker_id, "payload": payload}
        self.link.do(lambda r: r.xadd(self.key("episodes"), fields, maxlen=STREAM_MAX_ENTRIES, approximate=True))

    def ensure_trainer_group(self) -> None:
        def create(r: redis.Redis) -> None:
            try:
                r.xgroup_create(self.key("episodes"), TRAINER_GROUP, id="0", mkstream=True)
            except redis.ResponseError as error:
                if "BUSYGROUP" not in str(error):
                    raise

        self.link.do(create)

    def read_batches(self, consumer: str, block_s: float, pending: bool = False) -> list[ReceivedBatch]:
        """Read batches for the trainer's consumer group: new ones, or (pending=True) ones it read but never acknowledged."""
        start = "0" if pending else ">"

        def read(r: redis.Redis):
            try:
                return r.xreadgroup(
                    TRAINER_GROUP,
                    consumer,
                    {self.key("episodes"): start},
                    count=8,
                    block=None if pending else max(1, int(block_s * 1000)),
                )
            except redis.ResponseError as error:
                if "NOGROUP" not in str(error):
                    raise
                log.warning("consumer group missing (Redis restarted without its data?); recreating it")
                self.ensure_trainer_group()
                return []

        received = []
        for _stream, entries in self.link.do(read) or []:
            for stream_id, fields in entries:
                stream_id = _text(stream_id)
                payload = fields.get(b"payload") if b"payload" in fields else fields.get("payload")
                if payload is None:  # acknowledged-and-trimmed entry seen as pending
                    self.ack(stream_id)
                    continue
                try:
                    received.append(ReceivedBatch(stream_id, decode_batch(payload)))
                except CodecError as error:
                    log.error("dropping undecodable episode batch %s: %s", stream_id, error)
                    self.ack(stream_id)
        return received

    def ack(self, *stream_ids: str) -> None:
        if stream_ids:
            self.link.do(
                lambda r: (
                    r.xack(self.key("episodes"), TRAINER_GROUP, *stream_ids),
                    r.xdel(self.key("episodes"), *stream_ids),
                )
            )

    def mark_received(self, iteration: int, share: int) -> None:
        key = self.key(f"received:{iteration}")
        self.link.do(lambda r: (r.sadd(key, share), r.expire(key, 7 * 24 * 3600)))

    def received_shares(self, iteration: int) -> set[int]:
        members = self.link.do(lambda r: r.smembers(self.key(f"received:{iteration}")))
        return {int(_text(m)) for m in members}

    # ---- heartbeats -----------------------------------------------------------------------------
    def beat(self, worker_id: int, status: dict) -> None:
        body = json.dumps({**status, "worker_id": worker_id, "time": time.time()})
        self.link.do(lambda r: r.set(self.key(f"heartbeat:{worker_id}"), body, ex=HEARTBEAT_TTL_S))

    def live_workers(self) -> dict[int, dict]:
        def scan(r: redis.Redis) -> dict[int, dict]:
            found = {}
            for key in r.scan_iter(match=self.key("heartbeat:*"), count=100):
                raw = r.get(key)
                if raw is not None:
                    found[int(_text(key).rsplit(":", 1)[1])] = json.loads(raw)
            return found

        return self.link.do(scan)

    # ---- summaries for displays -----------------------------------------------------------------
    def publish(self, stream: str, record: dict) -> None:
        fields = {"json": json.dumps(record)}
        self.link.do(lambda r: r.xadd(self.key(stream), fields, maxlen=STREAM_MAX_ENTRIES, approximate=True))

    def read_records(self, stream: str, after_id: str = "0", block_s: float | None = None) -> list[tuple[str, dict]]:
        block = None if block_s is None else max(1, int(block_s * 1000))
        result = self.link.do(lambda r: r.xread({self.key(stream): after_id}, count=1000, block=block))
        records = []
        for _stream, entries in result or []:
            for stream_id, fields in entries:
                raw = fields.get(b"json") if b"json" in fields else fields.get("json")
                records.append((_text(stream_id), json.loads(raw)))
        return records

    def delete_run_keys(self) -> None:
        """Remove every key of this run (a fresh start with the same model prefix)."""

        def wipe(r: redis.Redis) -> None:
            keys = list(r.scan_iter(match=self.prefix + "*", count=500))
            if keys:
                r.delete(*keys)

        self.link.do(wipe)
