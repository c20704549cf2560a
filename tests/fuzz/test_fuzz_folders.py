"""Render folders with a truncated, flipped, emptied, missing or rewritten ``spectral.npz`` /
``meta.json`` / ``scene.json`` (NaN and negative radiance, wrong shapes, missing arrays, strings),
given to ``rigsim capture``; and study folders with damaged tables and case records given to
``rigsim report`` and resumed by ``rigsim study``: one ``error:`` line naming the file, or a
result with finite values."""

from __future__ import annotations

from hypothesis import given, settings

from tests.fuzz.cases import BUGS, FolderCase, folder_cases, run_folder_case


@settings(settings.get_profile("rigsim-fuzz"), max_examples=40)
@given(case=folder_cases())
def test_damaged_folders(case, ws):
    res = run_folder_case(case, ws, timeout=90)
    assert res.outcome not in BUGS, f"{res.outcome}: {res.detail}"


def test_truncated_spectral_npz_is_one_line(ws):
    """The issue's case: `rigsim capture DIR` on a render folder whose spectral.npz is truncated."""
    res = run_folder_case(FolderCase("render", "spectral.npz", "truncate", arg=900), ws)
    assert res.outcome == "refused" and "spectral.npz" in res.detail and "truncated" in res.detail, res.detail
    for damage in ("nan", "negative"):
        res = run_folder_case(FolderCase("render", "spectral.npz", damage, arg=5), ws)
        assert res.outcome == "refused" and "not finite or negative" in res.detail, res.detail


def test_a_zip_header_claiming_an_unknown_version_is_one_line(ws):
    """Found by tools/soak.py (10 000 cases, seed 2026): one flipped byte in spectral.npz's zip header
    made zipfile raise NotImplementedError ('zip file version 21.0'), which reached the user as an
    internal error."""
    res = run_folder_case(FolderCase("render", "spectral.npz", "flip", arg=9787, payload=b"\xd9"), ws)
    assert res.outcome == "refused", (res.outcome, res.detail)
    assert "spectral.npz" in res.detail
