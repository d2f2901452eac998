"""The reward: DeepRacer's params dict and users' reward functions, loaded and called."""
