"""Contact recording. The listener only records; the world decides what a contact means."""

from __future__ import annotations

from box2d_driving.physics.box2d_py import b2ContactListener

# Body kinds stored in fixture userData as (kind, index). Every road edge shares one tag,
# EDGE_TAG: nothing needs an edge's index, and a real junction has hundreds of edges.
CAR = "car"
EDGE = "edge"
PEDESTRIAN = "pedestrian"
EDGE_TAG = (EDGE, -1)

# Collision filter categories.
CAT_CAR = 0x0001
CAT_EDGE = 0x0002
CAT_PEDESTRIAN = 0x0004


class ContactRecorder(b2ContactListener):
    """Appends ``((kind_a, index_a), (kind_b, index_b))`` for every contact that starts touching."""

    def __init__(self) -> None:
        super().__init__()
        self.events: list[tuple[tuple[str, int], tuple[str, int]]] = []

    def BeginContact(self, contact) -> None:
        self.events.append((contact.fixtureA.userData, contact.fixtureB.userData))

    def drain(self) -> list[tuple[tuple[str, int], tuple[str, int]]]:
        """The contacts recorded since the last drain, oldest first; the record is emptied."""
        events, self.events = self.events, []
        return events
