"""Scene → SpectralImage with Mitsuba 3 (spectral volumetric path tracing).

* :func:`render` — the renderer (see :mod:`rigsim.render.renderer`);
* :mod:`rigsim.render.phase_plugin` — the wavelength-dependent phase-function plugin;
* :mod:`rigsim.render.emitter_plugin` — point lights with beam patterns;
* camera rays: from :mod:`rigsim.scene.optics` (the one camera and port model);
* :mod:`rigsim.render.targets`, :mod:`rigsim.render.mitsuba_scene` — the Mitsuba scene;
* :mod:`rigsim.render.variant` — the Mitsuba variant (all Mitsuba imports go through it).

Importing this package loads Mitsuba; import it only where rendering is needed.
"""

from rigsim.render.renderer import RENDER_LAYERS, band_edges, render

__all__ = ["RENDER_LAYERS", "band_edges", "render"]
