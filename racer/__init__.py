"""racer: a local, open DeepRacer-compatible training system (MuJoCo + PyTorch PPO + Redis + S3)."""

__version__ = "0.1.0"
