"""``report.html``: the table and interactive figures of ``quad-dob paper`` / ``evaluate``.

One self-contained file (plotly, its JavaScript inlined once, no network): the results
table, then per scenario a 3D view of the reference and every flown path, and time series
of the position error, the disturbance force against each observer's estimate, and the
thrust against its limit, all with hover and zoom. plotly is a dependency for this: a
well-kept library rather than hand-written JavaScript.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from quad_dob_training.rollout import Flight

_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2",
            "#17becf")
# the table scrolls sideways inside its own box, so a wide one (a score, its spread and the
# paired change for each) never pushes the page wider than the window
_STYLE = """body{font-family:system-ui,sans-serif;margin:24px;color:#222;max-width:1400px}
.table-box{overflow-x:auto;max-width:100%}
table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #ccc;padding:3px 8px;
text-align:right;white-space:nowrap}th{background:#f2f2f2;white-space:normal;
vertical-align:bottom;min-width:4em}td:first-child,td:nth-child(2){text-align:left}
p.note{max-width:60em;line-height:1.4}h2{margin-top:36px}"""
# the columns that compare a row with the baseline: the baseline's own row has no
# comparison, which the table says in words rather than as a change of 0 [0, 0]
_COMPARISON_MARK = "_diff_"


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


def _paths_figure(scenario: str, flights: Sequence[Flight]):
    import plotly.graph_objects as go

    figure = go.Figure()
    reference = flights[0].reference_position
    figure.add_trace(go.Scatter3d(x=reference[:, 0], y=reference[:, 1], z=reference[:, 2],
                                  mode="lines", name="reference",
                                  line={"color": "#999", "width": 3, "dash": "dash"}))
    for k, flight in enumerate(flights):
        p = flight.position
        figure.add_trace(go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="lines",
                                      name=flight.controller,
                                      line={"color": _COLOURS[k % len(_COLOURS)], "width": 4}))
    figure.update_layout(title=f"{scenario}: paths [m]", height=520,
                         scene={"aspectmode": "data", "xaxis_title": "x", "yaxis_title": "y",
                                "zaxis_title": "z"}, margin={"l": 0, "r": 0, "b": 0, "t": 40})
    return figure


def _series_figure(scenario: str, flights: Sequence[Flight]):
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    figure = make_subplots(rows=3, cols=1, shared_xaxes=True, vertical_spacing=0.07,
                           subplot_titles=("position error ‖x − x_d‖ [m]",
                                           "disturbance force [N]: true (black) and each "
                                           "observer's estimate",
                                           "collective thrust [N]: requested (dotted), applied "
                                           "and the limit"))
    truth = flights[0]
    for axis, dash in zip(range(3), ("solid", "dash", "dot"), strict=True):
        figure.add_trace(go.Scatter(x=truth.time, y=truth.disturbance_force[:, axis],
                                    name=f"true d_{'xyz'[axis]}", legendgroup="true",
                                    line={"color": "black", "dash": dash, "width": 1}),
                         row=2, col=1)
    for k, flight in enumerate(flights):
        colour = _COLOURS[k % len(_COLOURS)]
        error = np.linalg.norm(flight.position - flight.reference_position, axis=1)
        figure.add_trace(go.Scatter(x=flight.time, y=error, name=flight.controller,
                                    legendgroup=flight.controller, line={"color": colour}),
                         row=1, col=1)
        if flight.force_estimate.any():
            for axis, dash in zip(range(3), ("solid", "dash", "dot"), strict=True):
                figure.add_trace(go.Scatter(
                    x=flight.time, y=flight.force_estimate[:, axis], showlegend=False,
                    name=f"{flight.controller} d̂_{'xyz'[axis]}", legendgroup=flight.controller,
                    line={"color": colour, "dash": dash}), row=2, col=1)
        figure.add_trace(go.Scatter(x=flight.time, y=flight.applied_thrust, showlegend=False,
                                    name=f"{flight.controller} applied",
                                    legendgroup=flight.controller, line={"color": colour}),
                         row=3, col=1)
        figure.add_trace(go.Scatter(x=flight.time, y=flight.requested_thrust, showlegend=False,
                                    name=f"{flight.controller} requested",
                                    legendgroup=flight.controller,
                                    line={"color": colour, "dash": "dot"}), row=3, col=1)
    figure.add_hline(y=truth.thrust_limit, line={"color": "black", "dash": "dash"}, row=3,
                     col=1)
    figure.update_xaxes(title_text="time [s]", row=3, col=1)
    figure.update_layout(title=f"{scenario}: time series", height=820, hovermode="x unified",
                         margin={"l": 60, "r": 20, "b": 40, "t": 70})
    return figure


def write_report(path: Path, title: str, rows: Sequence[dict],
                 columns: Sequence[tuple[str, str]],
                 flights_by_scenario: dict[str, Sequence[Flight]], *,
                 baseline: str | None = None, notes: Sequence[str] = ()) -> Path:
    """Write the report; ``flights_by_scenario`` holds one flight per controller/policy.
    ``baseline``: the resolved spec of the policy the comparison columns are against
    (``policies.resolve_spec``; its row, the one whose ``policy_spec`` it is, says so
    instead of a change of zero); ``notes``: paragraphs of plain text shown under the title."""
    parts = [f"<h1>{html.escape(title)}</h1>",
             *(f"<p class='note'>{html.escape(note)}</p>" for note in notes),
             _table(rows, columns, baseline)]
    first = True
    for scenario, flights in flights_by_scenario.items():
        parts.append(f"<h2>{html.escape(scenario)}</h2>")
        for figure in (_paths_figure(scenario, flights), _series_figure(scenario, flights)):
            parts.append(figure.to_html(full_html=False, include_plotlyjs=first,
                                        config={"displaylogo": False}))
            first = False
    document = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>"
                f"{html.escape(title)}</title><style>{_STYLE}</style></head><body>"
                + "\n".join(parts) + "</body></html>")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(document, encoding="utf-8")
    return path
