"""Simulator generations (2019, simapp5, simapp6): a look and a car chosen by one name."""
