"""Markdown for the peer benchmark's rows: the full table (docs) and a summary (README).

Both go between HTML comment markers, so a new run replaces them in place:
``<!-- peers:table:begin -->`` ... ``<!-- peers:table:end -->`` in docs/performance.md and
``<!-- peers:summary:begin -->`` ... ``<!-- peers:summary:end -->`` in the README.

    .venv/bin/python -m benchmarks.peers.peers_table benchmarks/results/peers.json [BAUD]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

#: Marks a project row measured in a configuration other than the library's default (the
#: user's choice); the speed goals are judged on the default configuration only.
NOT_DEFAULT = "not the default"
#: The speed goals: the project beats the best Firmata client and the raw floor by this factor.
GOAL_FACTOR = {"a": 1.5, "b": 1.5, "c": 4.0, "d": 1.5, "e": 4.0}

TESTS = {
    "a": "host sets D2 -> host knows D3's new level (jumper)",
    "b": "one request/response round trip",
    "c": "4 analog channels at the shortest period accepted, per channel",
    "d": "digital writes per second that reach the pin (harness counts edges)",
    "e": "port open -> first command done, board resets on open",
}


def _ms(value: Any) -> str:
    return "-" if value is None else f"{value:.2f}"


def _rate(value: Any) -> str:
    return "-" if value is None else f"{value:,.0f}"


def render_markdown(rows: list[dict[str, Any]]) -> str:
    """One table per test, Firmata rows first, both links."""
    out = []
    for test, title in TESTS.items():
        chosen = [r for r in rows if r["test"] == test]
        if not chosen:
            continue
        out.append(f"**({test}) {title}**\n")
        if test in "cd":
            out.append("| link | system | client | baud | n | per second |")
            out.append("|---|---|---|---|---|---|")
            for r in chosen:
                out.append(
                    f"| {r['link']} | {r['system']} | {r['client']} | {r['baud']:,} | "
                    f"{r['n']:,} | {_rate(r['rate_per_s'])} |"
                )
        else:
            out.append("| link | system | client | baud | n | p50 ms | p90 ms | p99 ms | mean ms |")
            out.append("|---|---|---|---|---|---|---|---|---|")
            for r in chosen:
                out.append(
                    f"| {r['link']} | {r['system']} | {r['client']} | {r['baud']:,} | {r['n']} | "
                    f"{_ms(r['p50_ms'])} | {_ms(r['p90_ms'])} | {_ms(r['p99_ms'])} | "
                    f"{_ms(r['mean_ms'])} |"
                )
        out.append("")
    return "\n".join(out).rstrip() + "\n"


def _higher_is_better(test: str) -> bool:
    return test in "cd"


def _figure(r: dict[str, Any]) -> float:
    """What a test is judged by: rate for (c), (d); p50 for the latencies."""
    return float(r["rate_per_s"] if _higher_is_better(r["test"]) else r["p50_ms"])


def goals(rows: list[dict[str, Any]], default_baud: int) -> list[dict[str, Any]]:
    """Per test and link: the best Firmata row (the raw floor is one of them) against the
    project's best row at its default configuration, as a factor (>1: the project is
    better), with its speed goal."""
    out = []
    for test in TESTS:
        for link in ("16u2", "none"):
            here = [r for r in rows if (r["test"], r["link"]) == (test, link)]
            firmata = [r for r in here if r["system"] == "firmata"]
            project = [
                r
                for r in here
                if r["system"] == "arduinoio"
                and r["baud"] == default_baud
                and NOT_DEFAULT not in str(r["client"])
            ]
            if not firmata or not project:
                continue
            pick = max if _higher_is_better(test) else min
            peer = pick(firmata, key=_figure)
            best = pick(project, key=_figure)
            factor = (
                _figure(best) / _figure(peer)
                if _higher_is_better(test)
                else _figure(peer) / _figure(best)
            )
            out.append(
                {
                    "test": test,
                    "link": link,
                    "firmata_client": peer["client"],
                    "firmata": _figure(peer),
                    "project_client": best["client"],
                    "project": _figure(best),
                    "factor": round(factor, 2),
                    "goal": GOAL_FACTOR[test],
                    "met": factor >= GOAL_FACTOR[test],
                }
            )
    return out


def goal_table(rows: list[dict[str, Any]], default_baud: int) -> str:
    """Markdown of ``goals``: empty when there is nothing to compare (no Firmata rows)."""
    judged = goals(rows, default_baud)
    if not judged:
        return ""
    out = [
        f"**The speed goals** (the project at its default {default_baud:,} baud, best way; "
        "p50 for (a), (b), (e), rate for (c), (d))\n",
        "| test | link | best Firmata | project, default configuration | factor | goal |",
        "|---|---|---|---|---|---|",
    ]
    for g in judged:
        unit = "/s" if _higher_is_better(g["test"]) else " ms"
        out.append(
            f"| ({g['test']}) | {g['link']} | {g['firmata_client']}: {g['firmata']:,.2f}{unit} | "
            f"{str(g['project_client']).removeprefix('arduinoio_async: ')}: "
            f"{g['project']:,.2f}{unit} | {g['factor']:.2f}x | "
            f">= {g['goal']}x: {'met' if g['met'] else 'NOT met'} |"
        )
    return "\n".join(out) + "\n"


def _cell(r: dict[str, Any]) -> str:
    if r["test"] in "cd":
        return _rate(r["rate_per_s"]) + "/s"
    if r["test"] == "e":
        return f"{r['mean_ms'] / 1000:.2f} s"
    return f"{r['p50_ms']:.2f} ms"


def render_summary(rows: list[dict[str, Any]], default_baud: int) -> str:
    """One line per Firmata client and one for the project; "16u2 / none" in each cell
    (p50 for (a), (b), mean for (e)).  The project's variants share its line, named."""
    lines: dict[str, dict[str, list[str]]] = {}
    for r in rows:
        project = r["system"] == "arduinoio"
        name = (
            f"arduinoio_async ({default_baud:,})" if project else f"Firmata: {r['client']} (57,600)"
        )
        variant = str(r["client"]).removeprefix("arduinoio_async: ") if project else ""
        if project and r["baud"] != default_baud:
            variant += f" at {r['baud']:,} baud"
        cell = lines.setdefault(name, {}).setdefault(r["test"], [])
        pair = {link: "-" for link in ("16u2", "none")}
        for other in rows:
            if (other["client"], other["test"], other["baud"]) == (
                r["client"],
                r["test"],
                r["baud"],
            ):
                pair[other["link"]] = _cell(other)
        text = f"{pair['16u2']} / {pair['none']}"
        text = f"{variant}: {text}" if variant else text
        if text not in cell:
            cell.append(text)
    out = [
        "| client (baud) | (a) D2 set -> D3 known, p50 | (b) round trip, p50 | "
        "(c) analog /s per channel | (d) writes at the pin /s | (e) open -> first command |",
        "|---|---|---|---|---|---|",
    ]
    for name, cells in lines.items():
        row = [name] + ["<br>".join(cells.get(test, ["-"])) for test in "abcde"]
        out.append("| " + " | ".join(row) + " |")
    out.append("")
    out.append("Each cell: through the 16U2 bridge model / without it.")
    return "\n".join(out) + "\n"


def replace_between(text: str, name: str, content: str) -> str:
    """Replace what lies between ``<!-- peers:NAME:begin -->`` and its end marker."""
    begin, end = f"<!-- peers:{name}:begin -->", f"<!-- peers:{name}:end -->"
    if begin not in text or end not in text:
        raise ValueError(f"markers {begin} / {end} not found")
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{content}{end}{tail}"


if __name__ == "__main__":
    data = json.loads(Path(sys.argv[1]).read_text())["rows"]
    baud = int(sys.argv[2]) if len(sys.argv) > 2 else 1_000_000
    print(render_markdown(data))
    print(goal_table(data, baud))
    print(render_summary(data, baud))
