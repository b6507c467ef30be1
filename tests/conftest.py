"""Settings every test shares: pygame draws headless (no window, no display needed); the
hand-built junction the map tests read."""

import os

import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")


@pytest.fixture(scope="module")
def junction(tmp_path_factory):
    """A four-way junction imported from a hand-built OpenStreetMap file (``tests/osm_fixtures.py``),
    one per test module: the importer tests and the map file tests both read it."""
    from box2d_driving.maps.osm import import_junction
    from tests.osm_fixtures import four_way

    return import_junction(four_way(tmp_path_factory.mktemp("osm") / "four.osm"), 1)
