"""racer: a local, open DeepRacer-compatible training system (MuJoCo + PyTorch PPO + Redis + S3).

This folder is the `racer` package itself: the command line (`cli`, `local`: the local launcher) and the user's
tools around training (`analysis`, `compare`, `model_io`, `race`, `racing_line`, `recipe`, `track`, `reward`, `viewer`;
`options`: the options several commands share). The benchmarks are the repository's `benchmarks/`, not installed.
The other top-level folders install beneath it
(setup.py's PACKAGE_DIRS): shared/ is `racer.shared`, trainer/ `racer.trainer`, rollout_worker/ `racer.rollout_worker`,
evaluation_worker/ `racer.evaluation_worker`, tracks/ `racer.tracks`.
"""

__version__ = "0.1.0"
