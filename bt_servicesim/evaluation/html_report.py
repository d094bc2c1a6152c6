"""An evaluation's ``report.html``: the figures the evaluation computed, gathered for the page.

Design intent: the page shows what the evaluation already knows -- the summary and paired
comparisons of :mod:`bt_servicesim.evaluation.summary`, the failure groups of the Markdown
report, every episode's row -- and what the episodes' profiles add when they have them
(``profile.json``: the tree's per-node figures for the heat map, points by cause). Where a
section's data is absent the page says why instead of showing nothing. The page itself is
drawn by :mod:`bt_servicesim.records.html_report`.
"""

from __future__ import annotations

import html
import re
from collections.abc import Mapping, Sequence
from itertools import combinations
from pathlib import Path
from typing import Any

from bt_servicesim.evaluation.settings import PENALTY_KEYS, EvaluationSettings
from bt_servicesim.evaluation.summary import (
    completed_by_one,
    distinct_missions,
    exact_binomial_p,
    mean_or_none,
    paired_drop_off_times,
    paired_scores,
    played,
    sign_test,
    summarise,
    time_over_bound,
    unplayed,
)
from bt_servicesim.records.episode_view import episode_view
from bt_servicesim.records.html_report import HTML_NAME, render, write_page

MEASURES = (
    ("points_under", "points lost per episode while it or a node under it ran", " pts"),
    ("points_tip", "points lost per episode while it was the running leaf", " pts"),
    ("time_share", "share of the sim time it was RUNNING", ""),
    ("tip_share", "share of the sim time it was the running leaf", ""),
    ("failure_rate", "failures over its outcomes", ""),
    ("starts_per_episode", "starts per episode", ""),
    ("ran_share", "share of episodes it ran in", ""),
)
"""The heat map's measures: a column of the ``nodes`` profile table
(:mod:`bt_servicesim.evaluation.node_tables`), its name, its unit."""


def write_html_report(settings: EvaluationSettings, rows: list[dict[str, Any]], *,
                      revision: str, plots: Sequence[tuple[str, str]] = (),
                      svgs: Mapping[str, str] | None = None,
                      profiles: Mapping[str, list[dict[str, Any]]] | None = None) -> Path:
    """``report.html`` in ``settings.out``, from the rows the evaluation wrote; ``revision``
    says which checkout played them (as results.md does), ``plots`` are the (name, title) of
    the ``results_NAME.png`` plots written beside it, ``svgs`` the same drawn as SVG (by name),
    inlined where given; ``profiles`` the episodes' profile tables
    (:func:`~bt_servicesim.evaluation.node_tables.profile_tables`)."""
    path = settings.out / HTML_NAME
    context = evaluation_context(settings, rows, revision=revision, plots=plots, svgs=svgs,
                                 profiles=profiles)
    write_page(path, render(context))
    return path


def evaluation_context(settings: EvaluationSettings, rows: list[dict[str, Any]], *,
                       revision: str, plots: Sequence[tuple[str, str]] = (),
                       svgs: Mapping[str, str] | None = None,
                       profiles: Mapping[str, list[dict[str, Any]]] | None = None
                       ) -> dict[str, Any]:
    """Everything the evaluation's page shows (see :func:`~bt_servicesim.records.html_report.
    render`)."""
    episodes = [_episode(settings.out, row) for row in played(rows)]
    return {
        "mode": "evaluation",
        "title": "Evaluation results",
        "subtitle": [f"{settings.command_line}",
                     f"On {revision}: {settings.episodes} "
                     f"episodes per scenario set, every executive on the same seeds; speed "
                     f"{settings.speed:g}, mission time limit {settings.time_limit_s:g} sim s."],
        "notes": {
            "interval": "Completed: the share of episodes completed, with the 95 % Wilson "
                        "score interval over the distinct missions (one per seed). Time over "
                        "bound: mission time over the task's kinematic lower bound, over the "
                        "completed episodes. Penalties: mean per episode.",
            "paired": "Over distinct missions: which executive completed missions the other "
                      "did not (McNemar's exact test), the scores where both completed and the "
                      "time to the drop-off where both got there (sign tests).",
            "not_run": _not_run(settings, rows),
        },
        "summary": summary_rows(settings, rows),
        "paired": paired_rows(settings, rows),
        "plots": [{"title": title, "src": f"results_{name}.png",
                   "svg": inline_svg((svgs or {}).get(name), title=title)} for name, title in plots
                  if (svgs or {}).get(name) or (settings.out / f"results_{name}.png").is_file()],
        "heat": heat_map((profiles or {}).get("nodes")),
        "causes": (profiles or {}).get("causes") or [],
        "failures": failure_groups((profiles or {}).get("triage"), rows),
        "filters": {"executives": list(settings.executives),
                    "scenarios": list(settings.scenarios)},
        "episodes": episodes,
        "penalty_kinds": PENALTY_KEYS,
    }


def inline_svg(document: str | None, *, title: str) -> str | None:
    """An SVG document as an element to put in the page (no XML declaration or doctype), its
    size left to the page's style, named by ``title`` for a screen reader."""
    if not document or "<svg" not in document:
        return None
    element = re.sub(r"<metadata>.*?</metadata>\s*", "", document[document.index("<svg"):],
                     count=1, flags=re.DOTALL)
    label = html.escape(title, quote=True)
    return re.sub(r'^<svg([^>]*?) width="[^"]*" height="[^"]*"',
                  lambda match: f'<svg{match.group(1)} role="img" aria-label="{label}"', element,
                  count=1)


def _episode(out: Path, row: Mapping[str, Any]) -> dict[str, Any]:
    run_dir = Path(str(row.get("out") or out))
    episode = episode_view(run_dir, row, link_base=out)
    episode["page"] = (f"{episode['dir']}/{HTML_NAME}" if (run_dir / HTML_NAME).is_file()
                       else f"{episode['dir']}/")
    return episode


def _not_run(settings: EvaluationSettings, rows: list[dict[str, Any]]) -> str | None:
    counts = unplayed(settings, rows)
    if not counts:
        return None
    parts = ", ".join(f"{executive} {scenario}: {count}"
                      for (executive, scenario), count in sorted(counts.items()))
    return f"The evaluation was stopped early; episodes not played: {parts}."


# ----------------------------------------------------------------------------- the summary
def summary_rows(settings: EvaluationSettings, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per scenario set and executive, as results.md's tables."""
    table = []
    for scenario in settings.scenarios:
        for executive in settings.executives:
            group = [row for row in rows
                     if row["executive"] == executive and row["scenario"] == scenario]
            summary, bound = summarise(group), time_over_bound(group)
            interval = summary["success_interval"]
            success = f"{summary['success_rate']:.0%}" + (
                "" if interval is None else f" ({interval[0]:.0%}–{interval[1]:.0%})")
            table.append({
                "executive": executive, "scenario": scenario, "episodes": summary["episodes"],
                "success": success, "mean_score": summary["mean_score"],
                "median_score": summary["median_score"],
                "mean_sim_time_s": summary["mean_sim_time_s"],
                "over_bound_median": bound["median"], "over_bound_p90": bound["p90"],
                "penalties": summary["penalties"],
            })
    return table


def paired_rows(settings: EvaluationSettings, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Every pair of executives, set by set, over distinct missions."""
    missions = distinct_missions(rows)
    table = []
    for first, second in combinations(settings.executives, 2):
        for scenario in settings.scenarios:
            scores = paired_scores(missions, scenario, first, second)
            times = paired_drop_off_times(missions, scenario, first, second)
            only_first, only_second = completed_by_one(missions, scenario, first, second)
            table.append({
                "scenario": scenario, "first": first, "second": second,
                "only": _with_p(f"{only_first} / {only_second}",
                                exact_binomial_p(only_first, only_second)),
                "both": len(scores[0]), "first_score": mean_or_none(scores[0]),
                "second_score": mean_or_none(scores[1]), "lower": _below(*scores),
                "both_dropped": len(times[0]), "first_time": mean_or_none(times[0]),
                "second_time": mean_or_none(times[1]), "faster": _below(*times),
            })
    return table


def _with_p(text: str, p_value: float | None) -> str:
    return text if p_value is None else f"{text} (p {p_value:.2g})"


def _below(first: list[float], second: list[float]) -> str:
    below = sum(a < b for a, b in zip(first, second, strict=True))
    return _with_p(f"{below}/{len(first)}", sign_test(first, second))


# ---------------------------------------------------------------------------- the heat map
def heat_map(nodes: Sequence[Mapping[str, Any]] | None) -> dict[str, Any]:
    """The ``nodes`` profile table as one tree per executive and set, each node with its
    measures; or why there is none."""
    measures = [{"key": key, "label": label, "unit": unit} for key, label, unit in MEASURES]
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in nodes or ():
        groups.setdefault((str(row["executive"]), str(row["scenario"])), []).append(row)
    if not groups:
        return {"trees": [], "measures": measures, "why": (
            "No heat map: no episode has a profile.json (the per-node figures a run of a tree "
            "writes with its records; the baseline executive is not a tree)." if nodes is not None
            else "No heat map: this evaluation wrote no profile tables.")}
    trees = [_tree(f"{executive}, {scenario} ({group[0]['episodes']} profiled episodes)", group)
             for (executive, scenario), group in groups.items()]
    return {"trees": trees, "measures": measures, "default": MEASURES[0][0], "why": None,
            "note": "Each node's figure over the profiled episodes of its executive and set "
                    "(profiles.json's nodes table); the colour is its share of the largest. "
                    "Choose a measure; point at a node (or reach it with Tab) for all its "
                    "figures."}


def _tree(name: str, rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The nodes in tree order (the table keeps each profile's order, root first), each with
    its depth (from its path: a node's key extends its parent's)."""
    nodes: list[dict[str, Any]] = []
    stack: list[str] = []
    for row in rows:
        key = str(row["node"])
        while stack and not key.startswith(stack[-1] + "."):
            stack.pop()
        nodes.append({"key": key, "label": str(row.get("label") or key.rsplit(".", 1)[-1]),
                      "kind": str(row.get("type") or ""), "depth": len(stack),
                      "figures": {measure: row.get(measure) for measure, _, _ in MEASURES}})
        stack.append(key)
    _colour(nodes, MEASURES[0][0])
    return {"name": name, "nodes": nodes}


def _colour(nodes: list[dict[str, Any]], measure: str) -> None:
    """The colour and figure each node is written with, so the page reads without scripts."""
    top = max((node["figures"][measure] or 0.0 for node in nodes), default=0.0) or 1.0
    for node in nodes:
        value = node["figures"][measure] or 0.0
        share = value / top
        node["colour"] = _heat(share)
        node["ink"] = "#fff" if share > 0.6 else "inherit"
        node["shown"] = f"{value:.1f}" if abs(value) >= 0.05 else ""


def _heat(share: float) -> str:
    stops = ((255, 255, 255), (253, 208, 162), (241, 105, 19), (127, 39, 4))
    at = min(max(share, 0.0), 1.0) * (len(stops) - 1)
    low = int(at)
    high = min(low + 1, len(stops) - 1)
    fraction = at - low
    red, green, blue = (round(a + (b - a) * fraction) for a, b in zip(stops[low], stops[high],
                                                                          strict=True))
    return f"rgb({red},{green},{blue})"


# ------------------------------------------------------------------------- failure groups
def failure_groups(triage: Sequence[Mapping[str, Any]] | None,
                   rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The ``triage`` profile table's groups (failed episodes by the phase they reached, the
    node that failed last and why), each with the commands that play one again and show its
    tree where it failed."""
    if triage is None:
        failed = sum(not row.get("completed") for row in played(rows))
        return {"groups": [], "note": (f"{failed} episodes failed; this evaluation wrote no "
                                       "failure triage (profile tables).") if failed else None}
    listed = []
    for group in triage:
        seeds = ", ".join("the shipped task" if seed is None else str(seed)
                          for seed in group.get("seeds") or ())
        where = (f"{group['phase']}, {group['node']} failed last" if group.get("node") != "-"
                 else f"phase {group['phase']}" if group.get("phase") != "-" else "no profile")
        listed.append({
            "title": f"{group['executive']}, {group['scenario']}: {where}",
            "count": group["count"], "reason": group["reason"], "seeds": seeds,
            "commands": [command for command in (group.get("run"), group.get("replay"))
                         if command],
        })
    return {"groups": listed, "note": None}
