"""How close can any car model come to the real logs in the open-loop replay? (README.md)"""
