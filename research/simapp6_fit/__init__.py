"""The simapp6 car fitted to DeepRacer on AWS's 2026 logs, leaving one file out (README.md)."""
