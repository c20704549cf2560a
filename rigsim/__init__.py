"""rigsim — underwater camera and lighting-rig design simulator.

Data flows one way (see DESIGN.md):
config → water/light/scene → render/preview → sensor → metrics → study/report.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("rigsim")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
