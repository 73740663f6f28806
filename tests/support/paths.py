"""Where the tests find the project's files: its root, and the teapot's data."""

from pathlib import Path

#: The project's root folder (the checkout's).
ROOT = Path(__file__).resolve().parents[2]
#: The teapot's patches in Newell's format.
TEAPOT = ROOT / "scenes" / "data" / "teapot.txt"
