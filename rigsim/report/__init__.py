"""Plots and reports (matplotlib, self-contained HTML)."""
