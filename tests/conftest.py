"""Settings every test shares: pygame draws headless (no window, no display needed)."""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
