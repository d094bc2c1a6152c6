"""The HTML report (``report.html``): one self-contained page a person opens and clicks through.

Design intent: a page that opens from the file system, with no server and no network, and
stays readable without scripts. Jinja2 fills one template (``templates/report.html.j2``) for
both kinds of page -- an evaluation's (the summary, the heat map, the failure groups and every
episode) and a single run's (the episode alone) -- with the style sheet and the script inlined
and the data the script draws from embedded as JSON. Pictures stay files beside the page,
linked relatively, so the page is small and the directory can be moved whole.

This module knows the page, not where its figures come from: the evaluation
(:mod:`bt_servicesim.evaluation.html_report`) and the run hand it plain dicts, an episode's as
:func:`~bt_servicesim.records.episode_view.episode_view` makes it.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping, Sequence
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bt_servicesim.records.episode_view import episode_view

if TYPE_CHECKING:
    import jinja2

HTML_NAME = "report.html"
TEMPLATES = Path(__file__).with_name("templates")
COLUMNS = (
    ("executive", "executive", False), ("scenario", "set", False), ("seed", "seed", True),
    ("completed", "completed", False), ("score", "score", True),
    ("sim_time_s", "sim time (s)", True), ("over_bound", "time over bound", True),
)
"""The episodes' table before the penalties: (key in the episode's data, heading, numeric)."""


@cache
def _environment() -> jinja2.Environment:
    import jinja2

    return jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES),
                              autoescape=jinja2.select_autoescape(default=True),
                              trim_blocks=True, lstrip_blocks=True,
                              undefined=jinja2.StrictUndefined)


def render(context: Mapping[str, Any]) -> str:
    """The page for ``context``: ``mode`` ("evaluation" or "run"), ``title``, ``subtitle``
    (lines), ``episodes`` (episode views), ``penalty_kinds`` (the referee's, in the order the
    tables list them), and for an evaluation ``summary``, ``paired``, ``causes``, ``notes``,
    ``plots``, ``heat``, ``failures`` and ``filters``."""
    episodes = list(context["episodes"])
    strings: dict[str, int] = {}
    for episode in episodes:
        episode.setdefault("page", episode["dir"])
        episode["timeline"] = interned(episode["timeline"], strings)
    data = {"mode": context["mode"], "episodes": episodes, "heat": context.get("heat"),
            "strings": list(strings)}
    kinds = list(context["penalty_kinds"])
    return _environment().get_template("report.html.j2").render(
        **{**context, "episodes": episodes}, data=data,
        columns=[{"key": key, "label": label, "numeric": numeric} for key, label, numeric in (
            *COLUMNS, *((f"penalties.{kind}", kind.replace("_", " "), True) for kind in kinds))],
        css=(TEMPLATES / "report.css").read_text(encoding="utf-8"),
        js=(TEMPLATES / "report.js").read_text(encoding="utf-8"))


def interned(timeline: Mapping[str, Any], strings: dict[str, int]) -> dict[str, Any]:
    """The timeline with every name (checkpoint, phase, leaf, cause) an index into
    ``strings``, which it extends: a thousand episodes name the same few dozen leaves, and the
    page carries each name once."""
    def index(name: Any) -> int:
        return strings.setdefault(str(name), len(strings))

    names = timeline["names"]
    return {
        **{key: value for key, value in timeline.items() if key != "names"},
        "legs": [[start, end, index(name), bound] for start, end, name, bound
                 in timeline["legs"]],
        "phases": None if timeline["phases"] is None else [
            [start, end, index(name)] for start, end, name in timeline["phases"]],
        "leaves": [[start, end, index(names[leaf])] for start, end, leaf in timeline["leaves"]],
        "bookings": None if timeline["bookings"] is None else [
            [time, index(cause), points] for time, cause, points in timeline["bookings"]],
    }


def write_page(path: Path, text: str) -> None:
    """Write the page whole or not at all (a temporary file, then a rename)."""
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as stream:
            stream.write(text)
        os.chmod(temporary, 0o644)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_run_report(run_dir: Path, report: Mapping[str, Any]) -> Path:
    """``report.html`` of the run in ``run_dir`` whose report is ``report``."""
    episode = episode_view(run_dir, report, link_base=run_dir)
    seed = "the shipped task" if episode["seed"] is None else f"seed {episode['seed']}"
    text = render({
        "mode": "run", "title": f"Run of {episode['executive']} on {seed}",
        "subtitle": _run_subtitle(report), "episodes": [episode],
        "penalty_kinds": list(episode["penalties"]),
    })
    path = run_dir / HTML_NAME
    write_page(path, text)
    return path


def _run_subtitle(report: Mapping[str, Any]) -> Sequence[str]:
    lines = [f"Status {report.get('status')}; {report.get('timing') or 'unknown'} timing; "
             f"run id {report.get('run_id')}."]
    if report.get("reproduce"):
        lines.append(f"Played by: {report['reproduce']}")
    return lines
