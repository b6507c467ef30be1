"""The Box2D module of box2d-py, imported once without its SWIG deprecation warnings.

box2d-py's SWIG bindings make Python 3.11+ warn, at import, that three of their builtin types
have no ``__module__`` (``DeprecationWarning``, with a traceback into ``Box2D/Box2D.py``); the
warning is about how the wheel was built, not about anything a user can change, and it cluttered
every docs build and test run. Importing the names the world uses from here keeps the warnings to
this one import and leaves every other warning alone.
"""

from __future__ import annotations

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message=r"builtin type \w+ has no __module__ attribute",
                            category=DeprecationWarning)
    from Box2D import (b2_dynamicBody, b2BodyDef, b2ContactListener, b2EdgeShape, b2FixtureDef,
                       b2PolygonShape, b2RayCastCallback, b2World)

__all__ = ["b2BodyDef", "b2ContactListener", "b2EdgeShape", "b2FixtureDef", "b2PolygonShape", "b2RayCastCallback",
           "b2World", "b2_dynamicBody"]
