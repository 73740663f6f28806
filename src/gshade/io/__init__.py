"""Reading and writing: surface data formats (and, later, scene files and images)."""

from .newell import parse_newell, read_newell

__all__ = ["parse_newell", "read_newell"]
