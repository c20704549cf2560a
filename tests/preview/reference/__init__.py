"""FROZEN REFERENCE — not the engine.  The fast engine's image model as it was before the speed-ups.

This package is ``rigsim/preview/{model,forward,backscatter,geometry}.py`` of commit 1f0d6e9 verbatim, except
for its imports (this package instead of ``rigsim.preview``) and the multiple-scattering hook (refused
here).  It computes every layer the straightforward way — whole-image float64 arrays, the full-size
FFT, no caches, no threads — and is kept, unchanged, as the reference of
``tests/preview/test_preview_speed.py`` (the speed-ups leave the layers unchanged) and of
``benchmarks/bench_preview_speed.py`` (the time it takes).  Do not fix or extend it: change the engine.
"""
