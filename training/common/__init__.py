"""What every part of the trainer shares: the seed ranges (training, selection, report) and the
dataclass-as-CLI helper of every command. Imports only ``box2d_driving``."""
