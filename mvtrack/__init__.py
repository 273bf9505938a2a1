"""mvtrack: homography-based multiple-camera person tracking (Turk 2008) and its visual debugger."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("mvtrack")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
