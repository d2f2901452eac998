"""Route files designed by this project, in DeepRacer's `.npy` format. Import name: `racer.tracks` (package data)."""
