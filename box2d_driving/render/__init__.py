"""Drawing the world with pygame (headless or in a window) and recording videos."""
