"""Which car constants make racer's car replay real simtraces best, and how close does that get? (README.md)"""
