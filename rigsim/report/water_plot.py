"""The water verification figure: a, b, c spectra and VSFs beside Petzold's measurements."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rigsim.data import load_table
from rigsim.fileio import atomic_write_bytes
from rigsim.water.model import Water

#: Petzold (1972) stations drawn for comparison: column → label (Mobley's names).
PETZOLD_CURVES = {
    "beta_AUTEC8_per_m_sr": "Petzold clear ocean (AUTEC 8)",
    "beta_HAOCE11_per_m_sr": "Petzold coastal ocean (HAOCE 11)",
    "beta_NUC2040_per_m_sr": "Petzold turbid harbour (NUC 2040)",
}


def vsf_per_m_sr(water: Water, psi_rad: np.ndarray, wavelength_nm: float) -> np.ndarray:
    """Volume scattering function β(ψ; λ) = b(λ) · p(ψ; λ), 1/(m·sr)."""
    b = float(water.b_per_m(wavelength_nm))
    return b * water.phase.eval(np.cos(psi_rad), wavelength_nm)


def plot_waters(waters: list[Water], out: str | Path, *, wavelength_nm=np.arange(400.0, 701.0, 5.0),
                vsf_wavelength_nm: float = 530.0) -> Path:
    """Draw a(λ), b(λ), c(λ) for each water and their VSFs at ``vsf_wavelength_nm`` on log–log
    axes with Petzold's measured clear, coastal and turbid-harbour VSFs (530 nm filter).

    Returns the path written (PNG or any format matplotlib infers from the suffix).
    """
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 9), constrained_layout=True)
    (ax_a, ax_b), (ax_c, ax_v) = axes
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, w in enumerate(waters):
        col = colors[i % len(colors)]
        lo, hi = w.wavelength_range_nm
        wl = np.asarray(wavelength_nm, float)
        wl = wl[(wl >= lo) & (wl <= hi)]
        t = w.iop_table(wl)
        ax_a.semilogy(wl, t["a_per_m"], color=col, label=w.name)
        ax_b.semilogy(wl, t["b_per_m"], color=col, label=w.name)
        ax_c.semilogy(wl, t["c_per_m"], color=col, label=w.name)
        if lo <= vsf_wavelength_nm <= hi:
            psi = np.radians(np.geomspace(0.1, 180.0, 400))
            ax_v.loglog(np.degrees(psi), vsf_per_m_sr(w, psi, vsf_wavelength_nm), color=col, label=w.name)
    pz = load_table("water/petzold_1972_vsf.csv")
    for (colname, label), ls in zip(PETZOLD_CURVES.items(), ("--", "-.", ":")):
        ax_v.loglog(pz["angle_deg"], pz[colname], "k" + ls, label=label)
    for ax, q in ((ax_a, "absorption a"), (ax_b, "scattering b"), (ax_c, "attenuation c = a + b")):
        ax.set_xlabel("wavelength (nm)")
        ax.set_ylabel(f"{q} (1/m)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    ax_v.set_xlabel("scattering angle ψ (deg)")
    ax_v.set_ylabel(f"VSF β(ψ) at {vsf_wavelength_nm:g} nm (1/(m·sr))")
    ax_v.set_title("VSF: model (solid) vs Petzold 1972 measurements (black)")
    ax_v.grid(True, which="both", alpha=0.3)
    ax_v.legend(fontsize=7)
    out = Path(out)
    buf = io.BytesIO()
    fig.savefig(buf, format=out.suffix.lstrip(".") or "png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(out, buf.getvalue())
    return out
