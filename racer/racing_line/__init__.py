"""The car's fastest line round a track and its speed profile."""
