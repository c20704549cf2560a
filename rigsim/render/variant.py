"""Choose and set the Mitsuba variant once; every Mitsuba import in rigsim goes through here.

Preference: ``cuda_ad_spectral`` when a CUDA GPU is usable, else
``llvm_ad_spectral`` (needs libLLVM), else ``scalar_spectral`` with a warning
(correct but far too slow for real images: every ray runs Python code).
Set ``RIGSIM_MITSUBA_VARIANT`` to force one.

Before Dr.Jit is imported, :func:`rigsim.environment.ensure_usable_llvm` makes sure the libLLVM
it will load can compile its kernels (Debian 12's libLLVM 15 aborts the process on the first
render) and points ``DRJIT_LIBLLVM_PATH`` at one that can, or stops with one line saying what to
install.
"""

from __future__ import annotations

import functools
import os
import warnings

from rigsim.errors import EnvironmentProblem, RigsimError

__all__ = ["PREFERRED_VARIANTS", "is_jit", "mitsuba", "variant"]

#: Variants tried in order.
PREFERRED_VARIANTS = ("cuda_ad_spectral", "llvm_ad_spectral", "scalar_spectral")


@functools.cache
def _setup() -> tuple[object, object, str]:
    forced = os.environ.get("RIGSIM_MITSUBA_VARIANT")
    llvm = None
    if not forced or forced.startswith("llvm"):
        from rigsim.environment import ensure_usable_llvm

        llvm = ensure_usable_llvm()  # raises EnvironmentProblem for an LLVM that would abort the process
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as e:  # pragma: no cover - dependency missing
        raise RigsimError(f"Mitsuba 3 is not installed ({e}); `pip install mitsuba==3.9.*`") from None
    candidates = (forced,) if forced else PREFERRED_VARIANTS
    available = set(mi.variants())
    errors = []
    for v in candidates:
        if v not in available:
            errors.append(f"{v}: not built")
            continue
        if v.startswith("cuda") and not forced and not _has_cuda(dr):
            errors.append(f"{v}: no CUDA device")
            continue
        try:
            mi.set_variant(v)
            # Packet gathers are chosen per launch from how buffers happen to be laid out, so two
            # renders of the same scene could trace different kernels and compile twice (2-9 s
            # each for the rigsim integrator); without them a kernel is compiled once per
            # (rig, water, target kind) and reused, also from Dr.Jit's on-disk cache.
            dr.set_flag(dr.JitFlag.PacketOps, False)
            if v.startswith("llvm"):
                dr.zeros(mi.Float, 1).numpy()  # fails here if libLLVM is missing
                _check_llvm_version(dr, llvm)
        except EnvironmentProblem:
            raise
        except Exception as e:  # noqa: BLE001 - any failure means "try the next one"
            errors.append(f"{v}: {e}")
            continue
        if v.startswith("scalar"):
            warnings.warn("Mitsuba LLVM/CUDA back-ends unavailable (" + "; ".join(errors) +
                          "); falling back to scalar_spectral — rendering will be very slow. "
                          "Install libLLVM (e.g. `apt install libllvm19`) for the llvm_ad_spectral variant.",
                          RuntimeWarning, stacklevel=3)
        return mi, dr, v
    raise RigsimError("no usable Mitsuba spectral variant: " + "; ".join(errors))


def _check_llvm_version(dr, probed) -> None:
    """Refuse an LLVM that Dr.Jit loaded behind the check's back (imported earlier) and that is too old."""
    from rigsim.environment import INSTALL_HINT, MIN_LLVM_MAJOR

    try:
        major = int(dr.detail.llvm_version()[0])
    except Exception:  # noqa: BLE001 - no version to check
        return
    if probed is None and major < MIN_LLVM_MAJOR:
        path = os.environ.get("DRJIT_LIBLLVM_PATH", "the one Dr.Jit found")
        raise EnvironmentProblem(f"libLLVM {major} ({path}) cannot compile Dr.Jit's kernels (LLVM {major} aborts "
                                 f"on 'fminimum'); {INSTALL_HINT}")


def _has_cuda(dr) -> bool:
    try:
        return bool(dr.has_backend(dr.JitBackend.CUDA))
    except Exception:  # noqa: BLE001
        return False


def mitsuba():
    """``(mi, dr)`` with the variant set (chosen on first call)."""
    mi, dr, _ = _setup()
    return mi, dr


def variant() -> str:
    """Name of the Mitsuba variant in use."""
    return _setup()[2]


def is_jit() -> bool:
    """True for the vectorised (LLVM/CUDA) variants."""
    return not variant().startswith("scalar")
