"""Training scripts and the trainers (SB3 + SuperSuit); filled in by the training work."""
