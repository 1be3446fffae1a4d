"""The omnislam folder: a documented dataset format for data recorded elsewhere.

Specification: docs/datasets/folder-format.md; metadata schema: ``dataset.schema.json``.
``load_folder`` reads one as a Sequence, ``check_folder`` lists its problems, ``export_folder``
writes any Sequence in it.
"""

from omnislam.datasets.folder.layout import FORMAT_NAME, FORMAT_VERSION
from omnislam.datasets.folder.loader import check_folder, load_folder
from omnislam.datasets.folder.reader import is_folder
from omnislam.datasets.folder.writer import export_folder

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "check_folder",
    "export_folder",
    "is_folder",
    "load_folder",
]
