"""The report template (rotor_avc.interactive): plotly.js written once per folder beside the pages
and loaded from there, the contents built from the sections and figures, the selectors shown
where a plot needs them, curves thinned within their stated tolerance (checked by interpolating
the kept points back onto the full curve), numbers rounded, many traces coloured along a scale,
and the symmetric-log transform against hand-computed values."""
import os
import re

import numpy as np
import pytest

from rotor_avc.interactive import plot_data
from rotor_avc.interactive.page import (PLOTLY_FILE, Figure, key_value_table, page, page_files,
                                        plotly_js, write_page)
from rotor_avc.interactive.symlog import symlog, symlog_axis


def resonance(f_hz):
    """|1 / (1 - r^2 + 2 j zeta r)| of a mode at 20 Hz, zeta = 0.01: a sharp peak."""
    r = f_hz / 20.0
    return np.abs(1.0 / (1 - r ** 2 + 2j * 0.01 * r))


def test_plotly_is_written_once_per_folder_and_loaded_from_there(tmp_path):
    fig = Figure("a", "curve", [{"type": "scatter", "mode": "lines", "x": [1.0, 2.0],
                                 "y": [3.0, 4.0]}])
    first = write_page(tmp_path / "one.html", "one", [fig])
    script = tmp_path / PLOTLY_FILE
    assert script.read_text() == plotly_js() and page_files(first) == [first, script]
    stamp = script.stat().st_mtime_ns
    os.utime(script, ns=(stamp - 10**9, stamp - 10**9))        # an older copy, same content
    write_page(tmp_path / "two.html", "two", [fig])
    assert script.stat().st_mtime_ns == stamp - 10**9           # not rewritten
    script.write_text("stale")
    write_page(tmp_path / "three.html", "three", [fig])
    assert script.read_text() == plotly_js()                    # a different copy is replaced
    text = first.read_text()
    assert re.findall(r"<script src=\"([^\"]+)\"", text) == [PLOTLY_FILE]
    assert "http://" not in text and "https://" not in text
    assert len(text) < 20_000 < len(plotly_js())


def test_contents_link_every_section_and_figure():
    figs = [Figure(f"f{k}", f"plot {k}", []) for k in range(9)]
    text = page("t", ["<h2>Run</h2><p>x</p>", figs[0], "<h2>Run</h2>", *figs[1:],
                      '<h2 class="x">Notes &amp; more</h2>'])
    toc = re.search(r'<nav class="toc">(.*?)</nav>', text, re.S).group(1)
    links = re.findall(r'href="#([^"]+)"', toc)
    ids = re.findall(r'\sid="([^"]+)"', text)
    assert len(ids) == len(set(ids)) and set(links) <= set(ids)
    # 3 sections (the repeated heading gets its own anchor) and 9 figures
    assert links[:3] == ["sec-run", "fig-f0", "sec-run-2"] and len(links) == 3 + 9
    assert '<h2 id="sec-notes-more" class="x">' in text
    assert toc.count("<details>") == 1 and "8 plots" in toc      # the long section folded


def test_selectors_only_where_a_plot_has_that_quantity():
    speed = Figure("s", "over speed", [], speed_axis="x")
    magnitude = Figure("m", "spectrum", [], speed_axis=None, magnitude_key="y", unit="m")
    neither = Figure("n", "map", [], speed_axis=None)
    assert 'id="speed-unit"' in page("t", [speed]) and 'id="magnitude-unit"' not in page("t", [speed])
    assert 'id="magnitude-unit"' in page("t", [magnitude]) and 'id="speed-unit"' not in page("t", [magnitude])
    assert "<select" not in page("t", [neither])
    assert '<option value="hz" selected>' in page("t", [speed])
    assert '<option value="rpm" selected>' in page("t", [speed], speed_unit="rpm")


def test_a_thinned_magnitude_stays_within_its_tolerance_in_si_units_and_db():
    f = np.linspace(1.0, 60.0, 3000)
    y = resonance(f)
    out = plot_data.thinned({"type": "scatter", "mode": "lines", "x": f, "y": y, "name": "m"},
                            magnitude=True)
    assert out["name"] == "m" and out["x"][0] == f[0] and out["x"][-1] == f[-1]
    assert len(out["x"]) < len(f) / 5
    back = np.interp(f, out["x"], out["y"])                      # what the page draws
    assert np.all(np.abs(back - y) <= plot_data.MAGNITUDE_TOL_REL * y * (1 + 1e-9))
    back_db = np.interp(f, out["x"], 20 * np.log10(out["y"]))
    assert np.max(np.abs(back_db - 20 * np.log10(y))) <= plot_data.MAGNITUDE_TOL_DB + 1e-9


def test_a_curve_along_a_path_keeps_its_hover_text_and_shape():
    t = np.linspace(0, 2 * np.pi, 2000)
    trace = {"type": "scatter", "mode": "lines", "x": np.cos(t), "y": np.sin(t),
             "text": [f"{v:.17g}" for v in t]}
    out = plot_data.thinned(trace, magnitude=False)
    kept = np.array([float(v) for v in out["text"]])
    assert len(kept) < 200 and np.allclose(np.cos(kept), out["x"])
    for full, part in ((np.cos(t), out["x"]), (np.sin(t), out["y"])):
        back = np.interp(t, kept, part)
        assert np.max(np.abs(back - full)) <= plot_data.RANGE_TOL * 2.0 * (1 + 1e-9)


@pytest.mark.parametrize("trace", [
    {"type": "scatter", "mode": "markers", "x": np.arange(100.0), "y": np.arange(100.0)},
    {"type": "scatter", "mode": "lines", "x": np.arange(20.0), "y": np.arange(20.0)},
    {"type": "scatter", "mode": "lines", "x": np.arange(100.0), "y": np.r_[np.nan, np.ones(99)]},
])
def test_markers_short_curves_and_gaps_are_kept_whole(trace):
    assert plot_data.thinned(trace, magnitude=False) is trace


def test_numbers_are_rounded_to_six_significant_digits():
    assert plot_data.rounded({"a": [1.23456789e-7, 123456.789, 3], "b": "x"}) == \
        {"a": [1.23457e-7, 123457.0, 3], "b": "x"}


def test_more_traces_than_the_palette_get_distinct_colours_in_order():
    many = [{"type": "scatter", "name": str(k)} for k in range(21)]
    out = plot_data.coloured(many)
    colours = [t["line"]["color"] for t in out]
    assert len(set(colours)) == 21 and colours == plot_data.sequential_colours(21)
    few = many[:plot_data.PALETTE_SIZE]
    assert plot_data.coloured(few) is few
    fixed = [{"type": "scatter", "line": {"color": "red"}}] * 21
    assert plot_data.coloured(fixed) is fixed


def test_symlog_against_hand_values():
    # sign(x) log10(1 + |x|/x0): 9 -> 1, -99 -> -2, 0 -> 0, 0.5 with x0 = 0.5 -> log10 2
    np.testing.assert_allclose(symlog([9.0, -99.0, 0.0], 1.0), [1.0, -2.0, 0.0])
    assert symlog([0.5], 0.5)[0] == pytest.approx(np.log10(2.0))
    axis = symlog_axis([-350.0, -0.2], 1.0, "Re s [1/s]")
    assert axis["ticktext"] == ["-1000", "-100", "-10", "-1", "0"]
    np.testing.assert_allclose(axis["tickvals"], -np.log10(1 + np.array([1000, 100, 10, 1, 0])))
    assert "x0 = 1" in axis["title"]["text"]


def test_key_value_table_flattens_nested_settings():
    text = key_value_table({"window": "hann", "band_hz": [2.0, 400.0], "nested": {"a": 1}})
    assert "<td class=\"\">band_hz</td><td class=\"\">2, 400</td>" in text
    assert "a = 1" in text and "{" not in text
