"""The car's sensors: cameras, LIDAR, the observation they make and its gymnasium spaces."""
