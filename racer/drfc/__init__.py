"""DeepRacer-for-Cloud experiments, read as DRfC reads them and trained or evaluated by racer.

`racer train --drfc DIR` and `racer evaluate --drfc DIR` take a DRfC folder (run.env, system.env, worker-N.env,
custom_files/) as it is. The files are read with DRfC's own rules (deepracer-for-cloud 2eb1a1f1:
`bin/activate.sh` for run.env and system.env, `scripts/training/prepare-config.py` for worker-N.env), mapped onto
racer's settings (per-worker settings through racer's workers.json), and every variable racer cannot honour is
reported once. docs/coming-from-drfc.md is the user's page; `variables.VARIABLES` the table it is checked against.
"""
