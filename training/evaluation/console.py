"""Tables sized for a terminal: what ``quad-dob evaluate`` and ``paper`` print.

The files (``evaluation.md``, ``.csv``, ``.json``, ``leaderboard.md``, ``table.md``) hold
every column; the console gets the few a reader compares first, in at most ``WIDTH``
characters, with a legend that names what ``±`` and the intervals are.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence

from quad_dob_training.evaluation.ranking import Standing, ranked

WIDTH = 120  # characters: a laptop terminal's, and GitHub's code view without scrolling
# the widest a name column may grow before it is cut with an ellipsis (model paths)
NAME_WIDTH = 30
# the widest a header line grows before it wraps: a column is as wide as its cells, or this
HEADER_WIDTH = 14


def text_table(header: Sequence[str], rows: Sequence[Sequence[str]],
               width: int = WIDTH, names: int = 2) -> str:
    """Columns two spaces apart, each as wide as its widest cell; a header wider than its
    column wraps onto more lines at its spaces. The first ``names`` columns hold text,
    left-aligned and cut with "…" past ``NAME_WIDTH``, and further only while the table
    is wider than ``width``; the others, numbers, right-aligned. A table that is still
    wider, its headers wrapped and its names cut to 12, has its widest columns cut too:
    it never prints wider than ``width`` (given room for four characters a column)."""
    cells = [list(row) for row in rows]
    count = len(header)
    text_columns = list(range(min(names, count)))
    widths, floors = [], []
    for k in range(count):
        widest = max((len(row[k]) for row in cells), default=0)
        longest_word = max((len(word) for word in header[k].split()), default=0)
        floor = max(widest, longest_word)
        if k in text_columns:
            floor = min(floor, NAME_WIDTH)
        floors.append(floor)
        widths.append(floor if k in text_columns else max(floor, min(len(header[k]), HEADER_WIDTH)))

    def total() -> int:
        return sum(widths) + 2 * (count - 1)

    # too wide: first wrap the headers further, then cut the names
    while total() > width:
        roomy = max(range(count), key=lambda k: widths[k] - floors[k])
        if widths[roomy] > floors[roomy]:
            widths[roomy] -= 1
        elif any(widths[k] > 12 for k in text_columns):
            widths[max(text_columns, key=lambda k: widths[k])] -= 1
        elif max(widths) > 4:  # the last resort: cut the widest column's cells
            widths[max(range(count), key=lambda k: widths[k])] -= 1
        else:
            break

    def cut(text: str, size: int) -> str:
        return text if len(text) <= size else text[:size - 1] + "…"

    def line(row: Sequence[str]) -> str:
        return "  ".join(cut(text, size).ljust(size) if k in text_columns
                         else cut(text, size).rjust(size)
                         for k, (text, size) in enumerate(zip(row, widths, strict=True))
                         ).rstrip()

    wrapped = [textwrap.wrap(text, size, break_long_words=False) or [""]
               for text, size in zip(header, widths, strict=True)]
    depth = max(len(lines) for lines in wrapped)
    # each header's lines sit at the bottom, over its column
    head = [line([([""] * (depth - len(lines)) + lines)[level] for lines in wrapped])
            for level in range(depth)]
    return "\n".join([*head, "  ".join("-" * size for size in widths),
                      *(line(row) for row in cells)])


def mean_text(row: dict, key: str, scale: float, digits: int | None) -> str:
    """The mean ± the half-width of its 95 % interval, both to ``digits`` decimals (None:
    as many as give the mean three significant figures, so a 27 g vehicle's effort does
    not print as 0.000)."""
    value = row.get(f"{key}_mean")
    if value is None:
        return "—"
    if digits is None:
        magnitude = abs(value * scale)
        digits = 0 if magnitude == 0 or not math.isfinite(magnitude) else max(
            0, 2 - math.floor(math.log10(magnitude)))
    low, high = row.get(f"{key}_low"), row.get(f"{key}_high")
    spread = ("" if low is None or high is None or high == low
              else f" ± {(high - low) / 2 * scale:.{digits}f}")
    return f"{value * scale:.{digits}f}{spread}"


def _change(row: dict, baseline: str) -> str:
    """The paired change of the position error against the baseline: percent of the
    baseline's mean, and the change's 95 % interval in millimetres."""
    key = "rms_position_settled"
    if row.get("policy_spec", row.get("policy")) == baseline:
        return "baseline"
    if f"{key}_diff_mean" not in row:
        return "—"
    change = row[f"{key}_diff_mean"]
    base = row[f"{key}_mean"] - change
    percent = f"{change / base:+.0%}" if base > 0 else "n/a"
    low, high = row[f"{key}_diff_low"] * 1e3, row[f"{key}_diff_high"] * 1e3
    if low == high:
        return f"{percent} (one flight)"
    mark = "" if low > 0 or high < 0 else " n.s."
    return f"{percent} [{low:+.1f}, {high:+.1f}]{mark}"


def evaluation_table(rows: Sequence[dict], baseline: str | None) -> str:
    """One line per scenario and policy: position error, effort and command rate as means
    ± the 95 % interval's half-width, flights lost, and the change to ``baseline`` (the
    attitude errors are in the files)."""
    header = ["scenario", "policy", "RMS ‖e_x‖ [mm]", "effort [N m]",
              "command rate [N/s]", "lost"]
    if baseline:
        header.append("Δ ‖e_x‖ % [mm]")
    lines = []
    shown = None
    for row in rows:
        cells = [row["scenario"] if row["scenario"] != shown else "", row["policy"],
                 mean_text(row, "rms_position_settled", 1e3, 2),
                 mean_text(row, "rms_moment", 1.0, None),
                 mean_text(row, "rms_command_rate", 1.0, None),
                 f"{row['crashes']}/{row['flights']}"]
        if baseline:
            cells.append(_change(row, baseline))
        shown = row["scenario"]
        lines.append(cells)
    legend = ("± : half-width of the 95 % bootstrap interval of the mean over the seeds. "
              "effort: RMS of the moment's norm ‖M‖. "
              "lost: flights that ended before their time.")
    if baseline:
        legend += (f" Δ: paired change against {baseline}, in % of its mean, with the 95 % "
                   "interval of the change in mm; n.s.: the interval holds 0.")
    legend += (" Every column (attitude errors, spreads, the estimator's errors): evaluation.md"
               " and .csv.")
    return text_table(header, lines) + "\n\n" + textwrap.fill(legend, WIDTH)


def ranking_lines(rows: Sequence[dict]) -> str:
    """Each scenario's policies in rank (flights lost, then mean position error)."""
    lines = ["Rank per scenario (fewer flights lost first, then lower mean RMS ‖e_x‖):"]
    for scenario in dict.fromkeys(row["scenario"] for row in rows):
        standings = {row["policy"]: Standing(int(row["crashes"]),
                                             float(row["rms_position_settled_mean"]))
                     for row in rows if row["scenario"] == scenario}
        text = f"{scenario}: " + ", ".join(f"{rank}. {name}" for rank, name in
                                           enumerate(ranked(standings), 1))
        lines.append(textwrap.fill(text, WIDTH, subsequent_indent="    ",
                                   break_on_hyphens=False))
    return "\n".join(lines)
