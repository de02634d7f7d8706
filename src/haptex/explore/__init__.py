"""``haptex explore``: the force field, its gain and curl, loop energies of drawn paths and
simulated scans of a texture, in the browser (Bokeh server) or a Jupyter notebook.

The page computes nothing itself: :mod:`.model` turns the controls into library objects
and calls the library's functions; :mod:`.app` draws the results.
"""

from .app import ExplorerPage, app, serve
from .model import Settings

__all__ = ["ExplorerPage", "Settings", "app", "serve"]
