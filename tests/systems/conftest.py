"""Puts the repository root on sys.path, so that tests here import the test-only reference
systems as `tests.reference.<module>` (tests/reference/__init__.py says why they are not part
of the rpod package). Appended, so it shadows nothing installed."""

import pathlib
import sys

_ROOT = str(pathlib.Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)
