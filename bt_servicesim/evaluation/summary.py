"""Statistics over episode rows: success, scores, penalties, time over the kinematic bound, and
paired comparisons.

Plain functions over the rows the episodes wrote (one dict per episode), so they are tested
without running anything. Paired figures compare two executives on the same seeds only.

A few dozen seeds are a small sample, so the figures carry how far chance alone could move
them: the success rate a 95 % Wilson score interval (sound at rates near 0 and 1, where the
normal approximation is not), and each paired comparison an exact two-sided binomial test --
a sign test on which executive did better, episode by episode, and McNemar's exact test on the
episodes only one of the two completed. Both are closed forms the standard library computes
exactly (``statistics.NormalDist`` for the interval's quantile, ``math.comb`` for the binomial
tail); the tests check them against ``scipy.stats.binomtest``, whose import alone costs more CPU
than an evaluation's whole report.

Those figures count *missions*, not episodes: episodes that play the same task (the same set
and seed, as every episode of the ``default`` set plays the shipped task) are one mission,
since in lockstep every replay of it is the same mission (:func:`distinct_missions`). Sixteen
replays of one task are one observation, not sixteen.
"""

from __future__ import annotations

import json
import math
import statistics
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bt_servicesim.evaluation.settings import PENALTY_KEYS, EvaluationSettings, tree_digest


def played(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows of episodes that ran to an outcome: not those a stopped evaluation stopped."""
    return [row for row in rows if not row.get("not_run")]


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The summary of one executive's rows (``docs/reference/evaluation.md`` defines each figure).

    Episodes a stopped evaluation did not play to an outcome are counted as ``not_run`` and
    left out of every statistic; their rows are kept. (:func:`summary_of` also counts the
    episodes such an evaluation never started, which have no row.)
    """
    every = rows
    rows = played(every)
    completed = [row for row in rows if row["completed"]]
    scores = [float(row["score"]) for row in completed]
    missions = distinct_missions(rows)
    interval = success_interval(sum(bool(row["completed"]) for row in missions), len(missions))
    return {
        "episodes": len(rows),
        "success_rate": len(completed) / len(rows) if rows else 0.0,
        "success_interval": None if interval is None else [round(end, 4) for end in interval],
        "mean_score": mean_or_none(scores),
        "median_score": statistics.median(scores) if scores else None,
        "mean_sim_time_s": mean_or_none([float(row["sim_time_s"]) for row in completed]),
        "penalties": mean_penalties(rows),
        "wall_time_s": round(sum(episode_wall_s(row) for row in rows), 3),
        "not_run": len(every) - len(rows),
        "rows": every,
    }


def distinct_missions(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The played rows, one per executive, set and episode seed (the first): the rows that are
    independent observations. Episodes of one task replay one mission in lockstep."""
    first: dict[tuple[Any, Any, Any], dict[str, Any]] = {}
    for row in played(rows):
        key = (row.get("executive"), row.get("scenario"), row.get("episode_seed"))
        first.setdefault(key, row)
    return list(first.values())


CONFIDENCE = 0.95
"""The confidence level of the success rate's interval."""


def success_interval(successes: int, episodes: int) -> tuple[float, float] | None:
    """The Wilson score interval of a success rate at :data:`CONFIDENCE`; None without
    episodes."""
    if episodes <= 0:
        return None
    z = statistics.NormalDist().inv_cdf(1.0 - (1.0 - CONFIDENCE) / 2.0)
    rate = successes / episodes
    spread = z * z / episodes
    centre = (rate + spread / 2.0) / (1.0 + spread)
    half = z / (1.0 + spread) * math.sqrt(rate * (1.0 - rate) / episodes
                                          + spread / (4.0 * episodes))
    return max(0.0, centre - half), min(1.0, centre + half)


def exact_binomial_p(wins: int, losses: int) -> float | None:
    """Two-sided p-value of ``wins`` against ``losses`` if either were equally likely (the exact
    binomial test at 1/2): the sign test of paired values, McNemar's exact test of paired
    outcomes. None when there is nothing to compare."""
    trials = wins + losses
    if trials == 0:
        return None
    fewer = min(wins, losses)
    tail = sum(math.comb(trials, k) for k in range(fewer + 1))
    return min(1.0, 2.0 * tail / (1 << trials))


def sign_test(first: list[float], second: list[float]) -> float | None:
    """:func:`exact_binomial_p` of how often ``first`` is below ``second``, pair by pair, against
    how often above (ties left out)."""
    below = sum(a < b for a, b in zip(first, second, strict=True))
    above = sum(a > b for a, b in zip(first, second, strict=True))
    return exact_binomial_p(below, above)


def completed_by_one(rows: list[dict[str, Any]], scenario: str, first: str,
                     second: str) -> tuple[int, int]:
    """Missions of a set (:func:`distinct_missions`), played by both, that only ``first``
    completed and that only ``second`` completed (McNemar's discordant pairs)."""
    by_key = {(row["executive"], row.get("episode_seed")): bool(row["completed"])
              for row in distinct_missions(rows) if row["scenario"] == scenario}
    both = {episode for (_, episode) in by_key
            if (first, episode) in by_key and (second, episode) in by_key}
    only_first = sum(by_key[(first, n)] and not by_key[(second, n)] for n in both)
    only_second = sum(by_key[(second, n)] and not by_key[(first, n)] for n in both)
    return only_first, only_second


def mean_penalties(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Each penalty kind per episode, over the episodes the referee reported on."""
    refereed = [row["penalties"] for row in rows if row.get("penalties")]
    return {key: (sum(float(p.get(key, 0.0)) for p in refereed) / len(refereed)
                  if refereed else 0.0) for key in PENALTY_KEYS}


def summary_of(settings: EvaluationSettings, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """``summary.json``: each executive's name to its summary; ``not_run`` counts every planned
    episode that was not played, started or not."""
    summaries = {}
    for executive in settings.executives:
        own = [row for row in rows if row["executive"] == executive]
        summary = summarise(own)
        summary["not_run"] = settings.episodes * len(settings.scenarios) - summary["episodes"]
        summary["time_over_bound"] = {
            scenario: time_over_bound([row for row in own if row["scenario"] == scenario])
            for scenario in settings.scenarios}
        nav_params = settings.nav_params_of(executive)
        summary["nav_params"] = (None if nav_params is None else {
            "file": str(nav_params), "sha256": tree_digest(nav_params)})
        summaries[executive] = summary
    return summaries


def time_over_bound(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Mission time over the task's kinematic bound, over the completed episodes that have
    one: how many, the median and the 90th percentile (None without any), and the median
    bound itself (seconds)."""
    ratios = sorted(float(row["time_over_bound"]) for row in played(rows)
                    if row.get("completed") and row.get("time_over_bound") is not None)
    bounds = [float(row["kinematic_bound_s"]) for row in played(rows)
              if row.get("completed") and row.get("time_over_bound") is not None]
    return {
        "episodes": len(ratios),
        "median": round(statistics.median(ratios), 4) if ratios else None,
        "p90": round(percentile(ratios, 90.0), 4) if ratios else None,
        "median_bound_s": round(statistics.median(bounds), 3) if bounds else None,
    }


def percentile(values: list[float], percent: float) -> float:
    """The ``percent`` percentile by linear interpolation between the sorted values (numpy's
    default); one value is its own every percentile."""
    ordered = sorted(values)
    if len(ordered) == 1:
        return ordered[0]
    position = (len(ordered) - 1) * percent / 100.0
    low = int(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)


def unplayed(settings: EvaluationSettings,
             rows: list[dict[str, Any]]) -> dict[tuple[str, str], int]:
    """How many planned episodes of each (executive, set) were not played, started or not."""
    played_rows = played(rows)
    counts = {}
    for executive in settings.executives:
        for scenario in settings.scenarios:
            done = sum(row["executive"] == executive and row["scenario"] == scenario
                       for row in played_rows)
            if done < settings.episodes:
                counts[(executive, scenario)] = settings.episodes - done
    return counts


def paired_scores(rows: list[dict[str, Any]], scenario: str, first: str,
                  second: str) -> tuple[list[float], list[float]]:
    """Scores of ``first`` and ``second`` on the episodes of a set that both completed."""
    return paired_values(rows, scenario, first, second,
                         reached=lambda row: bool(row["completed"]),
                         value=lambda row: float(row["score"]))


def paired_drop_off_times(rows: list[dict[str, Any]], scenario: str, first: str,
                          second: str) -> tuple[list[float], list[float]]:
    """Task sim time to the drop-off (checkpoints 1–3) on the episodes both got that far."""
    return paired_values(rows, scenario, first, second, reached=_dropped_off,
                         value=lambda row: sum(float(checkpoint["sim_time_s"])
                                               for checkpoint in row["checkpoints"][:3]))


def paired_values(rows: list[dict[str, Any]], scenario: str, first: str, second: str, *,
                  reached: Callable[[dict[str, Any]], bool],
                  value: Callable[[dict[str, Any]], float]) -> tuple[list[float], list[float]]:
    """``value`` of ``first``'s and ``second``'s rows, episode by episode, on the episodes of
    a set where both rows satisfy ``reached``."""
    by_key = {(row["executive"], row["episode"]): row for row in rows
              if row["scenario"] == scenario and reached(row)}
    both = sorted({episode for (_, episode) in by_key
                   if (first, episode) in by_key and (second, episode) in by_key})
    return ([value(by_key[(first, n)]) for n in both],
            [value(by_key[(second, n)]) for n in both])


def _dropped_off(row: dict[str, Any]) -> bool:
    checkpoints = row.get("checkpoints") or []
    return len(checkpoints) >= 3 and all(bool(c.get("done")) for c in checkpoints[:3])


def mean_or_none(values: list[float]) -> float | None:
    return statistics.fmean(values) if values else None


def episode_wall_s(row: dict[str, Any]) -> float:
    return float(row.get("episode_wall_time_s") or row.get("wall_time_s") or 0.0)


# ------------------------------------------------------------------ reading an evaluation back
class SummaryFileError(ValueError):
    """An evaluation's summary that cannot be read back: the one-line reason."""


ROW_KEYS = ("scenario", "episode_seed", "completed", "score", "checkpoints")
"""What every played row of an evaluation holds, for the commands that read it back."""


def summary_rows(directory: Path, executive: str) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """``executive``'s played rows of the evaluation in ``directory``, and its summary entry."""
    summary_file = directory / "summary.json"
    try:
        summary = json.loads(summary_file.read_text())
    except OSError as error:
        raise SummaryFileError(f"{summary_file}: cannot read it ({error.strerror or error}); "
                               "is it an evaluation's --out directory?") from None
    except ValueError as error:
        raise SummaryFileError(f"{summary_file}: not JSON ({error})") from None
    entry = summary.get(executive) if isinstance(summary, dict) else None
    if not isinstance(entry, dict) or not isinstance(entry.get("rows"), list):
        known = ", ".join(sorted(summary)) if isinstance(summary, dict) else "none"
        raise SummaryFileError(f"{summary_file}: no rows of the {executive!r} executive "
                               f"(it has: {known})")
    rows = entry["rows"]
    if not all(isinstance(row, dict) for row in rows):
        raise SummaryFileError(f"{summary_file}: {executive}'s rows are not all objects")
    rows = played(rows)
    missing = next((key for row in rows for key in ROW_KEYS if key not in row), None)
    if missing is not None:
        raise SummaryFileError(f"{summary_file}: {executive}'s rows are not as an evaluation "
                               f"writes them (no {missing})")
    return rows, entry
