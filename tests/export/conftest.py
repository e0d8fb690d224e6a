"""The recorded-like scenarios of the co-simulation tests (`tests/cosim/real_like.py`) are used here too."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cosim"))
