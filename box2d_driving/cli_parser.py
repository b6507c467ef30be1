"""The argument parser every ``box2d-driving`` command uses (its own module so that the commands
the CLI dispatches to, such as ``bench``, can use it without importing the CLI back)."""

from __future__ import annotations

import argparse
from typing import Mapping


class OneLineParser(argparse.ArgumentParser):
    """argparse whose usage errors are one line (``PROG: error: ...``, status 2; no usage dump, no
    traceback). Every command's parser, the training scripts' included, is one."""

    commands: Mapping[str, argparse.ArgumentParser]  # a parser with sub-commands: name -> its parser

    def error(self, message: str):  # one line, no usage dump
        self.exit(2, f"{self.prog}: error: {message}\n")
