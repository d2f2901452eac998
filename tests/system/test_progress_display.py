"""`racer train`'s status line: a worker is "starting" until its first heartbeat, "DOWN" only once it was seen."""

from racer.local.run import ProgressDisplay
from racer.shared.redis_connection import RedisLink
from racer.shared.transport.channels import RunChannel


def test_a_worker_is_starting_until_its_first_heartbeat_and_down_only_after_it(redis_settings):
    channel = RunChannel(RedisLink(redis_settings), "display")
    lines: list[str] = []
    display = ProgressDisplay(channel, num_workers=2, started=0.0, echo=lambda text, err=False: lines.append(text))

    def status_line() -> str:
        display.last_status = 0.0
        display.poll()
        return lines[-1].split("workers ", 1)[1]

    assert status_line() == "w0:starting, w1:starting"
    channel.beat(1, {"state": "playing"})
    assert status_line() == "w0:starting, w1:playing"
    channel.link.client.delete(channel.key("heartbeat:1"))
    assert status_line() == "w0:starting, w1:DOWN"
