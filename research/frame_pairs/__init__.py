"""Do DeepRacer's policies read racer's frame and the Gazebo frame of the same pose alike? (README.md)"""
