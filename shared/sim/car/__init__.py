"""The car: geometry and MJCF, tyre forces, its dynamics profiles and their randomisation."""
