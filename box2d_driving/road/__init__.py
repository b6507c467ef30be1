"""Road geometry: paths, splines, traffic lights and the per-episode road layout."""
