"""The 2019 generation's car fitted on a 2020 console log, leaving one episode out (README.md)."""
