"""The Redis keys of one training run and the operations the trainer and the workers perform on them.

Keys (all under `racer:<run>:`, `<run>` = the model prefix):

| key | type | written by | meaning |
|---|---|---|---|
| `control` | stream | trainer | announcements: `iteration` (checkpoint k is ready, play it), `replay` (episodes went back to the queue: claim them), `finished` |
| `todo:<k>:<w>` | list | trainer, workers | episode numbers of iteration k not yet claimed, first those of worker w's DeepRacer share |
| `claimed:<k>:<w>` | list | workers, trainer | episodes worker w is playing; they go back to a todo list when its heartbeat lapses |
| `opened:<k>` | string | trainer | the todo lists of iteration k were filled (once) |
| `episodes` | stream, consumer group `trainer` | workers | one entry per episode of iteration k: an `Episode` (codec.py) that names its iteration and `episode_number` |
| `received:<k>` | set | trainer | episode numbers of iteration k the trainer already holds |
| `heartbeat:<worker>` | string with TTL | workers | JSON status (state, iteration, episodes, steps/s); absent = dead |
| `evaluations` | stream | worker 0 | greedy evaluation results per checkpoint |
| `iterations` | stream | trainer | per-iteration training summary (for progress displays and benchmarks) |
| `watching`, `frame:<worker>` | strings with TTL | viewer, workers | live camera frames for `racer view` (frames.py) |

Why streams: unlike DeepRacer's pub/sub, a stream entry waits until it is read, so nothing is lost when
a reader is busy or restarting; the consumer group keeps unacknowledged episodes for a restarted trainer.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Collection
from dataclasses import dataclass

import redis

from racer.shared.episode import Episode
from racer.shared.redis_connection import RedisLink
from racer.shared.transport.codec import CodecError, decode_episode, encode_episode

log = logging.getLogger(__name__)

TRAINER_GROUP = "trainer"
HEARTBEAT_TTL_S = 15
STREAM_MAX_ENTRIES = 10_000
CLAIM_KEYS_TTL_S = 7 * 24 * 3600

# Fills the todo lists of one iteration exactly once (also when the trainer announces it again after a restart):
# episode e goes to the list of worker e mod W, the SimApp's split (worker i plays episodes i, i+W, ...).
_OPEN_EPISODES = """
if not redis.call('SET', KEYS[1], '1', 'NX', 'EX', ARGV[1]) then return 0 end
local workers = #KEYS - 1
for e = 0, tonumber(ARGV[2]) - 1 do redis.call('RPUSH', KEYS[2 + e % workers], e) end
for i = 2, #KEYS do redis.call('EXPIRE', KEYS[i], ARGV[1]) end
return 1
"""


@dataclass(frozen=True)
class Announcement:
    """One entry of the control stream."""

    stream_id: str
    kind: str  # "iteration" | "replay" | "finished"
    iteration: int
    checkpoint: str = ""
    episodes_per_iteration: int = 0
    num_workers: int = 0
    target_worker: int = -1
    policy_version: int = -1
    """The checkpoint number `checkpoint` holds: the iteration itself, or one less when the trainer queued the
    iteration before its update (`overlap`); -1 on notices that name no checkpoint."""


@dataclass(frozen=True)
class ReceivedEpisode:
    stream_id: str
    episode: Episode


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
        self,
        iteration: int,
        checkpoint: str,
        episodes_per_iteration: int,
        num_workers: int,
        policy_version: int | None = None,
    ) -> None:
        """`policy_version`: the number of `checkpoint` when it is not `iteration` (an overlapped run)."""
        fields = {
            "kind": "iteration",
            "iteration": iteration,
            "checkpoint": checkpoint,
            "episodes_per_iteration": episodes_per_iteration,
            "num_workers": num_workers,
        }
        if policy_version is not None and policy_version != iteration:
            fields["policy_version"] = policy_version
        self.link.do(lambda r: r.xadd(self.key("control"), fields, maxlen=STREAM_MAX_ENTRIES, approximate=True))

    def request_replay(self, iteration: int, target_worker: int = -1) -> None:
        """Wake idle workers: episodes of `iteration` went back to the queue (`target_worker` -1: any worker)."""
        fields = {"kind": "replay", "iteration": iteration, "target_worker": target_worker}
        self.link.do(lambda r: r.xadd(self.key("control"), fields, maxlen=STREAM_MAX_ENTRIES, approximate=True))

    # ---- claimed episodes -----------------------------------------------------------------------
    def _todo(self, iteration: int, worker_id: int) -> str:
        return self.key(f"todo:{iteration}:{worker_id}")

    def _claimed(self, iteration: int, worker_id: int) -> str:
        return self.key(f"claimed:{iteration}:{worker_id}")

    def open_episodes(self, iteration: int, episodes: int, num_workers: int) -> bool:
        """Queue episodes 0..E-1 of an iteration, once; False when they were already queued."""
        keys = [self.key(f"opened:{iteration}")] + [self._todo(iteration, w) for w in range(num_workers)]
        return bool(self.link.do(lambda r: r.eval(_OPEN_EPISODES, len(keys), *keys, CLAIM_KEYS_TTL_S, episodes)))

    def claim_own(self, iteration: int, worker_id: int) -> int | None:
        """The next episode of worker `worker_id`'s own share, now held in its claimed list; None when none is left."""
        todo, claimed = self._todo(iteration, worker_id), self._claimed(iteration, worker_id)
        number = self.link.do(lambda r: r.lmove(todo, claimed, "LEFT", "RIGHT"))
        return None if number is None else int(number)

    def claim_other(self, iteration: int, worker_id: int, num_workers: int, live: Collection[int] = ()) -> int | None:
        """An unclaimed episode of another worker's share (the last of the longest queue): for a worker whose own
        share is done. The last queued episode of a `live` worker stays its own, so every live worker plays at
        least one episode of each iteration (and writes its simtrace, as in DeepRacer). None when nothing is left."""
        claimed = self._claimed(iteration, worker_id)
        while True:
            lengths = self.link.do(lambda r: self._lengths(r, iteration, num_workers))
            spare = [n - 1 if w in live and w != worker_id else n for w, n in enumerate(lengths)]
            longest = max(range(num_workers), key=lambda w: spare[w])
            if spare[longest] <= 0:
                return None
            source = self._todo(iteration, longest)
            number = self.link.do(lambda r, source=source: r.lmove(source, claimed, "RIGHT", "RIGHT"))
            if number is not None:
                return int(number)

    def _lengths(self, r: redis.Redis, iteration: int, num_workers: int) -> list[int]:
        pipe = r.pipeline(transaction=False)
        for w in range(num_workers):
            pipe.llen(self._todo(iteration, w))
        return pipe.execute()

    def deliver_episode(self, episode: Episode) -> None:
        """Push one claimed episode and drop its claim in one transaction: an episode is always either claimed,
        queued or delivered, whenever a worker dies."""
        fields = self._episode_fields(episode)
        claimed = self._claimed(episode.iteration, episode.worker_id)

        def deliver(r: redis.Redis) -> None:
            pipe = r.pipeline(transaction=True)
            pipe.xadd(self.key("episodes"), fields, maxlen=STREAM_MAX_ENTRIES, approximate=True)
            pipe.lrem(claimed, 1, episode.episode_number)
            pipe.execute()

        self.link.do(deliver)

    def release_claims(self, iteration: int, worker_id: int) -> list[int]:
        """Put the episodes worker `worker_id` holds back at the front of its queue (it died, or restarted holding
        nothing); returns their numbers."""
        todo, claimed = self._todo(iteration, worker_id), self._claimed(iteration, worker_id)
        released = []
        while (number := self.link.do(lambda r: r.lmove(claimed, todo, "RIGHT", "LEFT"))) is not None:
            released.append(int(number))
        return released

    def queued_and_claimed(self, iteration: int, num_workers: int) -> tuple[set[int], dict[int, set[int]]]:
        """One consistent snapshot: unclaimed episode numbers, and the claimed ones by worker."""

        def snapshot(r: redis.Redis):
            pipe = r.pipeline(transaction=True)
            for w in range(num_workers):
                pipe.lrange(self._todo(iteration, w), 0, -1)
                pipe.lrange(self._claimed(iteration, w), 0, -1)
            return pipe.execute()

        lists = self.link.do(snapshot)
        queued = {int(n) for todo in lists[0::2] for n in todo}
        claimed = {w: {int(n) for n in lists[2 * w + 1]} for w in range(num_workers)}
        return queued, claimed

    def requeue(self, iteration: int, numbers: list[int], num_workers: int) -> None:
        """Queue lost episode numbers again (Redis restarted without the newest writes)."""
        for number in numbers:
            self.link.do(lambda r, n=number: r.rpush(self._todo(iteration, n % num_workers), n))

    def forget_iteration(self, iteration: int, num_workers: int) -> None:
        """Drop an iteration's queues once it is trained."""
        keys = [self.key(f"opened:{iteration}")]
        keys += [self._todo(iteration, w) for w in range(num_workers)]
        keys += [self._claimed(iteration, w) for w in range(num_workers)]
        self.link.do(lambda r: r.delete(*keys))

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
            target_worker=int(f.get("target_worker", -1)),
            policy_version=int(f.get("policy_version", f["iteration"] if f.get("checkpoint") else -1)),
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
    @staticmethod
    def _episode_fields(episode: Episode) -> dict:
        return {
            "iteration": episode.iteration,
            "episode_number": episode.episode_number,
            "worker_id": episode.worker_id,
            "payload": encode_episode(episode),
        }

    def push_episode(self, episode: Episode) -> None:
        """Add an episode to the stream without a claim to drop (tests, and tools that feed a trainer)."""
        fields = self._episode_fields(episode)
        self.link.do(lambda r: r.xadd(self.key("episodes"), fields, maxlen=STREAM_MAX_ENTRIES, approximate=True))

    def ensure_trainer_group(self) -> None:
        def create(r: redis.Redis) -> None:
            try:
                r.xgroup_create(self.key("episodes"), TRAINER_GROUP, id="0", mkstream=True)
            except redis.ResponseError as error:
                if "BUSYGROUP" not in str(error):
                    raise

        self.link.do(create)

    def read_episodes(self, consumer: str, block_s: float, pending: bool = False) -> list[ReceivedEpisode]:
        """Read episodes for the trainer's consumer group: new ones, or (pending=True) ones it read but never
        acknowledged."""
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
                    received.append(ReceivedEpisode(stream_id, decode_episode(payload)))
                except CodecError as error:
                    log.error("dropping undecodable episode %s: %s", stream_id, error)
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

    def publish_newest_checkpoint(self, version: int, checkpoint: str) -> None:
        """An overlapped run: checkpoint `version` is complete in the store; workers take it up between episodes."""
        key = self.key("newest_checkpoint")
        self.link.do(lambda r: r.set(key, f"{version} {checkpoint}", ex=CLAIM_KEYS_TTL_S))

    def newest_checkpoint(self) -> tuple[int, str] | None:
        """(version, checkpoint name) the trainer last published, None before any (or in a strict run)."""
        value = self.link.do(lambda r: r.get(self.key("newest_checkpoint")))
        if value is None:
            return None
        version, checkpoint = _text(value).split(" ", 1)
        return int(version), checkpoint

    def mark_received(self, iteration: int, episode_number: int) -> None:
        key = self.key(f"received:{iteration}")
        self.link.do(lambda r: (r.sadd(key, episode_number), r.expire(key, 7 * 24 * 3600)))

    def received_episodes(self, iteration: int) -> set[int]:
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

    # ---- a run that cannot go on ----------------------------------------------------------------
    def report_fatal(self, source: str, message: str) -> None:
        """A process hit an error no restart can mend (the user's reward function raised): the run must stop.
        The first report stays; the trainer and `racer train` read it and stop with it."""
        body = json.dumps({"source": source, "message": message, "time": time.time()})
        self.link.do(lambda r: r.set(self.key("fatal"), body, nx=True))

    def fatal(self) -> dict | None:
        raw = self.link.do(lambda r: r.get(self.key("fatal")))
        return None if raw is None else json.loads(raw)

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
        """Remove every key of this run (a fresh start with the same model prefix) but the heartbeats: workers
        started beside the trainer are already beating, and a wiped heartbeat showed them all as down for a moment.
        A heartbeat left by an earlier run expires on its own within `HEARTBEAT_TTL_S`."""
        heartbeats = self.key("heartbeat:")

        def wipe(r: redis.Redis) -> None:
            keys = [
                key for key in r.scan_iter(match=self.prefix + "*", count=500) if not _text(key).startswith(heartbeats)
            ]
            if keys:
                r.delete(*keys)

        self.link.do(wipe)
