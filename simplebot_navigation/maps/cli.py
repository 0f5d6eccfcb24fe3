"""Command lines of the map tools: a bad argument is one line on stderr and exit code 2, not a usage block."""

from __future__ import annotations

import argparse


class OneLineParser(argparse.ArgumentParser):
    def error(self, message: str):
        self.exit(2, f"{self.prog}: {message} (--help for the usage)\n")
