"""The report's "How far to trust these numbers" table says where the Monte Carlo reference is heavy-tailed."""

from __future__ import annotations

from rigsim.report.html import trust_section


def _row(region, deviation, tail, verdict, distance_m=1.0):
    return {"rig": "r", "water": "jerlov-9C", "target": "colorchecker", "distance_m": distance_m, "tolerance": 0.05,
            "width": 96, "height": 64, "spp": 32, "seeds": 16, "quantity": "radiance", "region": region,
            "group": "blue", "deviation": deviation, "deviation_se": 0.04, "verdict": verdict, "monte_carlo_tail": tail}


def test_the_trust_table_names_a_heavy_tailed_target_and_not_a_light_tailed_one(tmp_path):
    # at 1 m the worst patch is light-tailed itself but another patch of the same chart had one render 57x the
    # median; at 3 m every region is light-tailed
    rows = [_row("patch:red", 0.32, 1.8, "disagrees"), _row("patch:yellow", -0.2, 56.7, "within noise"),
            _row("open water", -0.066, 1.1, "disagrees")]
    html = "".join(trust_section(tmp_path, rows, {}))
    assert "Monte Carlo heavy-tailed on this target (a region&#x27;s render 57× the median)" in html
    assert "title='open water, blue, 1 m'>" in html  # the open water's cell: its own tail only
    calm = [_row("patch:red", 0.32, 1.8, "disagrees", 3.0), _row("patch:yellow", 0.02, 1.3, "agrees", 3.0)]
    assert "heavy-tailed on" not in "".join(trust_section(tmp_path, calm, {}))


def test_the_trust_table_says_which_cases_are_referenced_by_the_hybrid_estimate(tmp_path):
    rows = [_row("patch:red", 0.02, 1.1, "agrees"), _row("open water", -0.01, 1.0, "agrees")]
    assert "hybrid estimate" not in "".join(trust_section(tmp_path, rows, {}))
    hybrid = [{**r, "reference": "hybrid"} for r in rows] + [
        {**_row("disk", 0.01, 1.0, "agrees", 3.0), "target": "black-disk", "reference": "monte-carlo"}]
    html = "".join(trust_section(tmp_path, hybrid, {}))
    assert "One chart case lit by strobes is referenced by the hybrid estimate" in html


def test_the_trust_table_says_how_many_renders_a_speck_share_was_measured_on(tmp_path):
    """With marine snow the checks render the particles' light for their pilot's renders alone (compute_check):
    the report says on how many renders the speck share stands, and says nothing of it without one."""
    rows = [_row("patch:red", 0.02, 1.1, "agrees"), _row("open water", -0.01, 1.0, "agrees")]
    assert "speck share (marine snow) on the first" not in "".join(trust_section(tmp_path, rows, {}))
    speck = {**_row("target", 0.03, None, "agrees"), "quantity": "speck_share", "group": "luminance", "seeds": 4}
    html = "".join(trust_section(tmp_path, rows + [speck], {}))
    assert "the speck share (marine snow) on the first 4 renders of each case" in html
