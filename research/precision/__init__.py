"""Does a bf16 tower learn as fast as fp32? (README.md)"""
