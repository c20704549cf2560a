"""The rig designer's package-side pieces (no physics here).

* :mod:`rigsim.config.rigdoc` (in the config layer, shared with the optimiser) — a rig file as an
  editable document: the UI's edits
  (arm length, aim, beam, power …) become the rig file's own keys, validated by
  :func:`rigsim.config.rig.parse_rig`, and written back as the same TOML.
* :mod:`rigsim.ui.files` — the folders the app may read and write (``rigs/`` and
  one folder the user chose); everything else is refused.
* :mod:`rigsim.ui.predict` — rig + water + distance + sensor → predicted image and
  its numbers (contrast, SNR, ΔE, backscatter share), with the fast preview model
  when present and a small Monte Carlo render otherwise.
* :mod:`rigsim.ui.scene3d` — PyVista meshes of the rig, beams, frustum, targets and
  the tinted water.
* :mod:`rigsim.ui.app` — the trame web app (``rigsim app``).
"""
