"""File formats exchanged by every stage of the NVRQ toolkit (see docs/FORMATS.md).

Layer: data_schema (file formats), the lowest layer.

``data_schema`` imports nothing else of this project.
"""

from data_schema.errors import InputError

__all__ = ["InputError"]
