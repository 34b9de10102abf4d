"""Make the synthetic-pair helper importable as ``synth`` from the tests of this folder."""

from __future__ import annotations

import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
