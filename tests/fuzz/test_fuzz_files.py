"""Generated rig, water, sensor, study and dataset files — valid ones and mutations (out of range,
NaN/inf, wrong types, unknown and misspelt keys, empty, huge, unicode, binary, truncated, deeply
nested): each is refused with one line naming the file, or accepted with a finite, non-negative
result (a preview render, an IOP table, a capture, a study run, drawn dataset samples)."""

from __future__ import annotations

from hypothesis import given, settings

from tests.fuzz.cases import BUGS, ROOT, config_cases, run_config_case


def _check(case, ws):
    res = run_config_case(case, ws, timeout=60)
    assert res.outcome not in BUGS, f"{res.outcome}: {res.detail}"


@settings(settings.get_profile("rigsim-fuzz"), max_examples=40)
@given(case=config_cases(("rig",)))
def test_rig_files(case, ws):
    _check(case, ws)


@settings(settings.get_profile("rigsim-fuzz"), max_examples=40)
@given(case=config_cases(("water",)))
def test_water_files(case, ws):
    _check(case, ws)


@settings(settings.get_profile("rigsim-fuzz"), max_examples=30)
@given(case=config_cases(("sensor",)))
def test_sensor_files(case, ws):
    _check(case, ws)


@settings(settings.get_profile("rigsim-fuzz"), max_examples=30)
@given(case=config_cases(("study",)))
def test_study_files(case, ws):
    _check(case, ws)


@settings(settings.get_profile("rigsim-fuzz"), max_examples=30)
@given(case=config_cases(("dataset",)))
def test_dataset_files(case, ws):
    _check(case, ws)


def test_file_damage_found_by_fuzzing(ws, tmp_path):
    """Cases the fuzzing found (deep nesting, over-long names, huge wavelength grids, NUL in names,
    binary and non-UTF-8 files): one line naming the file each."""
    from tests.fuzz.cases import ConfigCase

    cases = [
        ConfigCase("water", b"[water]\nchl_mg_per_m3 = 1\nx = " + b"[" * 5000 + b"]" * 5000 + b"\n", ["deep"]),
        ConfigCase("water", b'[water]\na_per_m = "' + b"a" * 300 + b'"\nb_per_m = 0.1\n', ["long name"]),
        ConfigCase("water", b'[water]\na_per_m = "x\\u0000y.csv"\nb_per_m = 0.1\n', ["NUL in a name"]),
        ConfigCase("study", f'[study]\nname="x"\n[sweep]\nrigs=["{ROOT}/rigs/twin-strobes-45-wide.toml"]\n'
                   'sensors=["sony_ilce-7rm2"]\nwaters=["coastal"]\ndistances_m=[1]\n[render]\n'
                   'wavelengths="400:1e15:1"\n'.encode(), ["huge grid"]),
        ConfigCase("rig", bytes(range(256)), ["binary"]),
        ConfigCase("rig", "[camera]\nfocal_length_mm = 24 # caf\u00e9\n".encode("latin-1"), ["latin-1"]),
        ConfigCase("sensor", b"\xef\xbb\xbf" + b"[sensor]\n", ["BOM"]),
    ]
    for c in cases:
        res = run_config_case(c, ws)
        assert res.outcome == "refused", (c.ops, res.outcome, res.detail)
        if c.ops == ["huge grid"]:
            assert "wavelengths" in res.detail and "10000" in res.detail, res.detail


def test_turbid_water_previews_are_finite(ws):
    """Found by the fuzzing: large particles at 100 ppm and more (c ≈ 30 /m) made the fast engine's
    forward-scattering kernel inf/inf = NaN (expm1 overflow)."""
    from tests.fuzz.cases import ConfigCase

    for conc in (100, 1000, 1e6):
        res = run_config_case(ConfigCase("water", f"[water]\nlargePartConc = {conc}\n".encode(), ["turbid"]), ws)
        assert res.outcome == "ok", (conc, res.outcome, res.detail)
    res = run_config_case(ConfigCase("water", b"[water]\na_per_m = 1e4\nb_per_m = 1e4\nphase = 'hg:0.9'\n",
                                     ["iops"]), ws)
    assert res.outcome == "ok", res.detail


def test_a_dataset_with_no_object_kinds_is_refused(ws):
    """Found by tools/soak.py (10 000 cases, seed 2026): ``kinds = []`` reached ``rng.choice`` (a
    ValueError traceback) instead of being refused when the spec was read."""
    from tests.fuzz.cases import ConfigCase

    doc = (ROOT / "tests" / "data" / "tiny-dataset.toml").read_text()
    assert 'kinds = ["colorchecker"]' in doc
    doc = doc.replace('kinds = ["colorchecker"]', "kinds = []")
    res = run_config_case(ConfigCase("dataset", doc.encode(), ["empty kinds"]), ws)
    assert res.outcome == "refused" and "kinds" in res.detail, (res.outcome, res.detail)
