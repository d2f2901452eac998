"""Experience transport between rollout workers and the trainer (Redis Streams), and its wire codec."""
