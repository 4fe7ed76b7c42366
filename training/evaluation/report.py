"""``report.html``: the table and interactive figures of ``quad-dob paper`` / ``evaluate``.

The report holds the results table (in a box that scrolls both ways, its header row and, on
a wide window, its first column kept in view), a line of links to the scenarios, then per
scenario a 3D view of the reference and every flown path, and time series of the position
error, the disturbance force against each observer's estimate, and the thrust against its
limit, all with hover and zoom. plotly draws them: a well-kept library rather than
hand-written JavaScript. Its JavaScript (about 4.8 MB) is one file, ``plotly.min.js``,
written beside the report and loaded by a relative ``<script src>``: nothing is fetched
from the network, so it opens offline from file://, and each report's folder has its own
copy (copy the two files together; without the library the page says so where each figure
would be).

What keeps it small (``quad-dob evaluate --suite``, 6 policies x 16 scenarios, draws about
700 traces, 900 arrays of numbers: with every sample as text the report was 25 MB, now
about 0.8 MB): each trace is thinned for display to a common number of points
(``_points_per_trace``: at most about a screen's width, fewer when the report's budget of
numbers is shared by many traces; ``_envelope`` keeps a noisy series' extremes), the numbers
are sent as float32 (base64, which plotly.js reads as typed arrays: 5.4 bytes a number here
against 7.0 for four significant digits as text), a time series sends its sampling step
instead of its times, and plotly's default template (6.5 kB) is sent once rather than with
each of the 32 figures.
"""

from __future__ import annotations

import html
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from quad_dob_training.rollout import Flight

_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2",
            "#17becf")
# The table is wider than a 1280 px window (a score, its spread and the paired change for
# each). It scrolls sideways inside its own box, never widening the page; the box is at
# most 80 % of the window tall, so its sideways scrollbar can be on screen rather than under
# the last of ~100 rows, and the header row (and on a wide window the scenario column) stays
# in view while it scrolls. Sticky cells need border-collapse: separate.
_STYLE = """body{font-family:system-ui,sans-serif;margin:24px;color:#222;max-width:1400px}
@media (max-width:600px){body{margin:12px}}
.table-box{overflow:auto;max-width:100%;max-height:80vh;border:1px solid #ccc}
table{border-collapse:separate;border-spacing:0;font-size:13px}
td,th{border:solid #ccc;border-width:0 1px 1px 0;padding:3px 8px;text-align:right;
white-space:nowrap;background:#fff}
th{background:#f2f2f2;white-space:normal;vertical-align:bottom;min-width:4em;position:sticky;
top:0;z-index:2}td:first-child,td:nth-child(2){text-align:left}
@media (min-width:900px){td:first-child,th:first-child{position:sticky;left:0;z-index:1}
th:first-child{z-index:3}}
p.note{max-width:60em;line-height:1.4}h2{margin-top:36px}
.figure{width:100%}.figure p{color:#a00}"""
# the columns that compare a row with the baseline: the baseline's own row has no
# comparison, which the table says in words rather than as a change of 0 [0, 0]
_COMPARISON_MARK = "_diff_"
# plotly's JavaScript, written beside the report and loaded from there
PLOTLY_JS = "plotly.min.js"
# Points a trace keeps for display. A plot is at most about a screen wide (~1000 px), so
# more points than that draw nothing new: _MAX_POINTS. The whole report shares a budget of
# numbers (float32, 5.4 bytes each as base64: ~650 kB, which with the table and the figures'
# layouts keeps a suite's report under 1 MB), so a report of many traces thins each further,
# to no fewer than _MIN_POINTS (one point per 10 samples of a 1000-sample flight).
_MAX_POINTS = 1000
_NUMBER_BUDGET = 120_000
_MIN_POINTS = 100
_MISSING_JS = (f"This figure is drawn by {PLOTLY_JS}, which is written beside report.html: "
               "it is missing here (copy the two files together).")
# one function draws every figure: plotly's template once for all, and a message in place
# of a figure when the library beside the report is missing
_DRAW = """function draw(id, figure) {
  var box = document.getElementById(id);
  if (!window.Plotly) { box.innerHTML = "<p>" + MISSING + "</p>"; return; }
  figure.layout.template = TEMPLATE;
  if (box.clientWidth < 600) {  // a phone: the legend under the plot rather than beside it
    figure.layout.legend = {orientation: "h", yref: "container", y: 0, yanchor: "bottom"};
    figure.layout.height += 160;
    box.style.height = figure.layout.height + "px";
    // and the long subplot titles on two lines, after their unit
    (figure.layout.annotations || []).forEach(function (note) {
      note.text = note.text.replace("]: ", "]:<br>");
    });
  }
  Plotly.newPlot(box, figure.data, figure.layout, CONFIG);
}"""
_CONFIG = {"displaylogo": False, "responsive": True}


def _table(rows: Sequence[dict], columns: Sequence[tuple[str, str]],
           baseline: str | None = None) -> str:
    head = "".join(f"<th>{html.escape(label)}</th>" for _, label in columns)
    body = []
    for row in rows:
        cells = []
        # the baseline is its resolved spec; a model's row is named shorter than its spec
        is_baseline = (baseline is not None
                       and row.get("policy_spec", row.get("policy")) == baseline)
        for key, _ in columns:
            value = row.get(key)
            if is_baseline and _COMPARISON_MARK in key:
                text = "baseline"
            else:
                text = ("—" if value is None else f"{value:.4g}" if isinstance(value, float)
                        else str(value))
            cells.append(f"<td>{html.escape(text)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<div class='table-box'><table><tr>{head}</tr>{''.join(body)}</table></div>"


def _arrays_drawn(flights: Sequence[Flight]) -> int:
    """The number of arrays the two figures of one scenario send: x, y, z of the reference
    and each path; the three true disturbance components; per flight the error, the two
    thrusts and, with an observer, its three estimates."""
    return 3 * (1 + len(flights)) + 3 + sum(3 + 3 * bool(f.force_estimate.any())
                                            for f in flights)


def _points_per_trace(flights_by_scenario: dict[str, Sequence[Flight]]) -> int:
    arrays = sum(_arrays_drawn(flights) for flights in flights_by_scenario.values()
                 if flights)
    return int(np.clip(_NUMBER_BUDGET // max(arrays, 1), _MIN_POINTS, _MAX_POINTS))


def _stride(flights: Sequence[Flight], points: int) -> int:
    """Samples per drawn point in a scenario's figures: one for all its flights, so that the
    unified hover finds every trace at the same times."""
    return max(1, math.ceil(max(len(f.time) for f in flights) / points))


def _envelope(values: np.ndarray, stride: int) -> np.ndarray:
    """A time series thinned for display to one point per ``stride`` samples: two points per
    run of ``2 stride`` samples, drawn at the middles of its two halves (evenly spaced, so
    sent as a start and a step). A run that turns at most once (a smooth stretch) gives the
    series' values at those two times. A run that turns more often gives its lowest and
    highest sample, in the order they came, each drawn less than 1.5 ``stride`` samples
    from when it came: every ``stride``-th sample alone would draw a noisy signal (a gust,
    an observer's estimate, a policy's thrust) as a thinner, calmer line than it is and cut
    its peaks; the extremes keep the band the full trace fills on screen. float32: 7
    significant digits, more than a plot shows; plotly sends it as a base64 typed array."""
    if stride == 1 or len(values) == 0:
        return np.ascontiguousarray(values, dtype=np.float32)
    run = 2 * stride
    count = -(-len(values) // run)
    runs = np.pad(values, (0, count * run - len(values)), mode="edge").reshape(count, run)
    each = np.arange(count)
    at = each[:, None] * run + np.array([stride - 1, 3 * stride - 1]) / 2
    drawn = np.interp(at, np.arange(count * run), runs.ravel())
    signs = np.sign(np.diff(runs, axis=1))
    noisy = (signs[:, 1:] * signs[:, :-1] < 0).sum(axis=1) >= 2
    low, high = runs.argmin(axis=1), runs.argmax(axis=1)
    drawn[noisy, 0] = runs[each, np.minimum(low, high)][noisy]
    drawn[noisy, 1] = runs[each, np.maximum(low, high)][noisy]
    # the last run is padded with the last sample: none is drawn after the last sample's time
    kept = max(1, int((len(values) - 1 - (stride - 1) / 2) // stride) + 1)
    return drawn.ravel()[:kept].astype(np.float32)


def _path(values: np.ndarray, stride: int) -> np.ndarray:
    """A 3D path at every ``stride``-th sample (a smooth curve: its points are enough), its
    last point kept (where a flight ended)."""
    rows = np.arange(0, len(values), stride)
    if rows[-1] != len(values) - 1:
        rows = np.append(rows, len(values) - 1)
    return np.ascontiguousarray(values[rows], dtype=np.float32)


def _paths_figure(scenario: str, flights: Sequence[Flight], stride: int):
    import plotly.graph_objects as go

    figure = go.Figure()
    reference = _path(flights[0].reference_position, stride)
    figure.add_trace(go.Scatter3d(x=reference[:, 0], y=reference[:, 1], z=reference[:, 2],
                                  mode="lines", name="reference",
                                  line={"color": "#999", "width": 3, "dash": "dash"}))
    for k, flight in enumerate(flights):
        p = _path(flight.position, stride)
        figure.add_trace(go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="lines",
                                      name=flight.controller,
                                      line={"color": _COLOURS[k % len(_COLOURS)], "width": 4}))
    figure.update_layout(title=f"{scenario}: paths [m]", height=520,
                         scene={"aspectmode": "data", "xaxis_title": "x", "yaxis_title": "y",
                                "zaxis_title": "z"}, margin={"l": 0, "r": 0, "b": 0, "t": 40})
    return figure


def _series_figure(scenario: str, flights: Sequence[Flight], stride: int):
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    def series(flight: Flight, values: np.ndarray, **options) -> go.Scatter:
        # the samples are dt apart from the flight's start: the step, not the times, is sent
        start = float(flight.time[0]) + flight.dt * (stride - 1) / 2  # see _envelope
        return go.Scatter(x0=start, dx=float(flight.dt * stride),
                          y=_envelope(values, stride), **options)

    figure = make_subplots(rows=3, cols=1, shared_xaxes=True, vertical_spacing=0.07,
                           subplot_titles=("position error ‖x − x_d‖ [m]",
                                           "disturbance force [N]: true (black) and each "
                                           "observer's estimate",
                                           "collective thrust [N]: requested (dotted), applied "
                                           "and the limit"))
    truth = flights[0]
    for axis, dash in zip(range(3), ("solid", "dash", "dot"), strict=True):
        figure.add_trace(series(truth, truth.disturbance_force[:, axis],
                                name=f"true d_{'xyz'[axis]}", legendgroup="true",
                                line={"color": "black", "dash": dash, "width": 1}),
                         row=2, col=1)
    for k, flight in enumerate(flights):
        colour = _COLOURS[k % len(_COLOURS)]
        error = np.linalg.norm(flight.position - flight.reference_position, axis=1)
        figure.add_trace(series(flight, error, name=flight.controller,
                                legendgroup=flight.controller, line={"color": colour}),
                         row=1, col=1)
        if flight.force_estimate.any():
            for axis, dash in zip(range(3), ("solid", "dash", "dot"), strict=True):
                figure.add_trace(series(
                    flight, flight.force_estimate[:, axis], showlegend=False,
                    name=f"{flight.controller} d̂_{'xyz'[axis]}", legendgroup=flight.controller,
                    line={"color": colour, "dash": dash}), row=2, col=1)
        figure.add_trace(series(flight, flight.applied_thrust, showlegend=False,
                                name=f"{flight.controller} applied",
                                legendgroup=flight.controller, line={"color": colour}),
                         row=3, col=1)
        figure.add_trace(series(flight, flight.requested_thrust, showlegend=False,
                                name=f"{flight.controller} requested",
                                legendgroup=flight.controller,
                                line={"color": colour, "dash": "dot"}), row=3, col=1)
    figure.add_hline(y=float(truth.thrust_limit), line={"color": "black", "dash": "dash"},
                     row=3, col=1)
    figure.update_xaxes(title_text="time [s]", row=3, col=1)
    # the whole flight: the thinned points start and end up to a stride inside it
    figure.update_xaxes(range=[min(float(f.time[0]) for f in flights),
                               max(float(f.time[-1]) for f in flights)])
    figure.update_layout(title=f"{scenario}: time series", height=820, hovermode="x unified",
                         margin={"l": 60, "r": 20, "b": 40, "t": 70})
    return figure


def _anchor(scenario: str) -> str:
    return "scenario-" + "".join(c if c.isalnum() or c in "-_." else "-" for c in scenario)


def _json(value) -> str:
    """Compact JSON to put inside a <script>: numpy arrays are already plotly's base64 dicts
    (``to_plotly_json``); ``<`` is escaped so that no string can close the script."""
    def plain(item):
        if isinstance(item, np.ndarray):
            return item.tolist()
        if isinstance(item, np.generic):
            return item.item()
        raise TypeError(f"not JSON: {type(item).__name__}")

    return json.dumps(value, separators=(",", ":"), ensure_ascii=False,
                      default=plain).replace("<", "\\u003c")


def _write_plotly_js(folder: Path) -> None:
    """plotly's JavaScript beside the report, rewritten only when it differs."""
    from plotly.offline import get_plotlyjs

    target = folder / PLOTLY_JS
    script = get_plotlyjs().encode("utf-8")
    if not (target.is_file() and target.stat().st_size == len(script)
            and target.read_bytes() == script):
        target.write_bytes(script)


def write_report(path: Path, title: str, rows: Sequence[dict],
                 columns: Sequence[tuple[str, str]],
                 flights_by_scenario: dict[str, Sequence[Flight]], *,
                 baseline: str | None = None, notes: Sequence[str] = ()) -> Path:
    """Write the report; ``flights_by_scenario`` holds one flight per controller/policy.
    ``baseline``: the resolved spec of the policy the comparison columns are against
    (``policies.resolve_spec``; its row, the one whose ``policy_spec`` it is, says so
    instead of a change of zero); ``notes``: paragraphs of plain text shown under the title.
    With figures, plotly's JavaScript is written beside it as ``plotly.min.js``."""
    parts = [f"<h1>{html.escape(title)}</h1>",
             *(f"<p class='note'>{html.escape(note)}</p>" for note in notes),
             _table(rows, columns, baseline)]
    points = _points_per_trace(flights_by_scenario)
    drawn_scenarios = [name for name, flights in flights_by_scenario.items() if flights]
    if drawn_scenarios:
        # many scenarios make a long page: a line of links to each one's figures
        parts.append("<p class='note'>Figures: " + " · ".join(
            f"<a href='#{_anchor(name)}'>{html.escape(name)}</a>" for name in drawn_scenarios)
            + "</p>")
    template, number = None, 0
    for scenario in drawn_scenarios:
        flights = flights_by_scenario[scenario]
        parts.append(f"<h2 id='{_anchor(scenario)}'>{html.escape(scenario)}</h2>")
        stride = _stride(flights, points)
        for figure in (_paths_figure(scenario, flights, stride),
                       _series_figure(scenario, flights, stride)):
            drawn = figure.to_plotly_json()
            # every figure has plotly's default template: the page sends it once
            template = drawn["layout"].pop("template", {}) if template is None else template
            drawn["layout"].pop("template", None)
            number += 1
            parts.append(f"<div class='figure' id='figure-{number}' "
                         f"style='height:{figure.layout.height}px'></div>"
                         f"<script>draw('figure-{number}',{_json(drawn)})</script>")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    head = (f"<meta charset='utf-8'><meta name='viewport' content='width=device-width, "
            f"initial-scale=1'><title>{html.escape(title)}</title><style>{_STYLE}</style>")
    if template is not None:
        _write_plotly_js(path.parent)
        head += (f"<script src='{PLOTLY_JS}'></script><script>var TEMPLATE={_json(template)};"
                 f"var CONFIG={_json(_CONFIG)};var MISSING={_json(html.escape(_MISSING_JS))};"
                 f"\n{_DRAW}</script>")
    document = (f"<!DOCTYPE html><html><head>{head}</head><body>" + "\n".join(parts)
                + "</body></html>")
    path.write_text(document, encoding="utf-8")
    return path
