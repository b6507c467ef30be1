"""The Box2D world: bodies, velocity control along paths, and contact events."""
