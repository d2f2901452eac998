"""Tracks: route files, DeepRacer's geometry of a point, the SimApp's track names and routes."""
