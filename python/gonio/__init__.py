"""gonio from Python: goniod's socket (Client), capture directories
(read_capture) and fitted model files evaluated by gonio's own C code
(Model). Standard library only; numpy arrays when numpy is installed.
docs/python.md."""
from .client import Client, GonioError, CAPTURE_FIELDS
from .capture import Capture, read_capture
from .model import Model

__all__ = ["Client", "GonioError", "CAPTURE_FIELDS", "Capture", "read_capture", "Model"]
