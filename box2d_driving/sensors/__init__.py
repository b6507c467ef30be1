"""Sensors: the LiDAR (:mod:`.lidar` casts the rays, :mod:`.readout` turns distances into observation values)."""
