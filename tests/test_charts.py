"""moonbot.charts: the same data gives the same SVG bytes, render after render, with the text kept
as text and the bars as long as their values."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import pytest

from moonbot.charts import COLOURS, bar_panels_svg, time_error_plot

pytestmark = pytest.mark.unit

SVG = "{http://www.w3.org/2000/svg}"
PANELS = [
    {
        "title": "throughput",
        "axis_label": "samples/s",
        "rows": [("host-a", [2.0], "2 /s"), ("host-b", [1.0], "1 /s")],
        "colours": [COLOURS[0]],
    },
    {
        "title": "stages",
        "axis_label": "s",
        "rows": [("host-a", [0.25, 0.75], "1 s"), ("host-b", [1.5, -1.0], "1.5 s")],
        "series": ["render", "encode"],
    },
]


def texts(svg: bytes) -> list[str]:
    return [t.text for t in ET.fromstring(svg).iter(f"{SVG}text") if t.text]


def test_two_renders_give_the_same_bytes(tmp_path):
    first, second = bar_panels_svg("moonbot", PANELS), bar_panels_svg("moonbot", PANELS)
    assert first == second
    assert ET.fromstring(first).tag == f"{SVG}svg"
    assert b"<dc:date>" not in first  # no date in the metadata
    curves = {"a": [(0.1, 1.0, "k=1"), (1.0, 0.1, "k=2")], "b": [(0.2, 0.5, "x"), (0.0, 0.05, "zero")]}
    time_error_plot(tmp_path / "one.svg", "t", curves)
    time_error_plot(tmp_path / "two.svg", "t", curves)
    assert (tmp_path / "one.svg").read_bytes() == (tmp_path / "two.svg").read_bytes()
    assert {"k=1", "k=2", "x", "zero", "a", "b"} <= set(texts((tmp_path / "one.svg").read_bytes()))


def test_text_stays_text_and_bars_scale_with_their_values():
    svg = bar_panels_svg("moonbot", PANELS)
    expected = {"moonbot", "throughput", "stages", "host-a", "host-b", "2 /s", "1.5 s", "render", "encode"}
    assert expected <= set(texts(svg))
    # The first panel's bars, in the first colour: host-a's is twice host-b's.
    fill = COLOURS[0]
    widths = []
    for path in ET.fromstring(svg).iter(f"{SVG}path"):
        if f"fill: {fill}" in (path.get("style") or ""):
            xs = [float(x) for x in re.findall(r"(-?\d+(?:\.\d+)?) -?\d+(?:\.\d+)?", path.get("d"))]
            widths.append(max(xs) - min(xs))
    # host-a and host-b of the first panel, then the 'render' segments of the second (and its legend patch).
    assert abs(widths[0] / widths[1] - 2.0) < 1e-3
