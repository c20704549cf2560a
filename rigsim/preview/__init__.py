"""Scene → SpectralImage in well under a second: the Jaffe–McGlamery model with spectral IOPs.

* :func:`render_preview` — the preview (see :mod:`rigsim.preview.model` for the model,
  its references and its limits); same inputs and outputs as :func:`rigsim.render.render`;
  :func:`render_photon_batches` — the same image with each batch of the multiple-scattering photons
  (the photons' noise in a number measured on the image);
* :mod:`rigsim.preview.forward` — small-angle forward scattering (blur kernels);
* :mod:`rigsim.preview.backscatter` — the single-scattering integral along each ray;
* :mod:`rigsim.preview.geometry` — ray casting, shadows (numpy; triangle meshes by Mitsuba's intersector).
* :mod:`rigsim.preview.tiles` — tiles of rows on threads (how the per-pixel passes use every core).

Camera rays, the phase function's tables and the daylight field come from the scene's
optics layer (:mod:`rigsim.scene.optics`, :mod:`rigsim.scene.phase_tables`,
:mod:`rigsim.scene.daylight_field`), shared with the renderer.

Importing this package does not load Mitsuba (a scene with a mesh target does, for its triangles).
"""

from rigsim.preview.model import PREVIEW_LAYERS, RENDERER_NAME, band_edges, render_photon_batches, render_preview

__all__ = ["render_preview", "render_photon_batches", "PREVIEW_LAYERS", "RENDERER_NAME", "band_edges"]
