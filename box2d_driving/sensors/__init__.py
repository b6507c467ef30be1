"""Sensors: the LiDAR."""
