"""What the evaluation's ``report.html`` costs at scale: written, its size, opened and sorted.

``python benchmarks/report_html.py [--episodes N] [--runs R] [--log-lines L] [--keep DIR]``
makes a synthetic evaluation of N episodes (default 1000: two executives, two scenario sets),
each the files a real episode leaves -- ``report.json`` with every field a run and the
evaluation write; for the tree executive a ``tree_log.jsonl`` of L tick lines (default 2500,
a real mission's count) whose tip changes as often as a real mission's (a dozen times) and the
``profile.json`` the profile's own code builds from it (130 nodes, the shipped tree's size,
points booked near walkers every other second of half the mission); a ``trajectory.png`` for
each failed episode -- and the evaluation's profile tables, and then, R times (default 3):

* ``written``: the wall time of writing ``report.html`` (the page alone: summary.json, the
  profile tables, the plots and results.md are written before it; scipy, which their
  statistics import, is imported before the clock starts; the plots are left out);
* ``size``: the page's bytes (the pictures are files beside it, not counted);
* ``first render``: in headless Chromium (Debian's, through Selenium), the time from the
  navigation's start to its first contentful paint, and to the load event;
* ``sort``: clicking the score column's heading, sorting ascending then descending (two
  figures per run): until the rows are sorted and laid out (the script's and the layout's
  time, layout forced), and until the next frame is drawn (a timer after the next animation
  frame, which a busy machine also delays).

``written`` is also given in CPU seconds, which move less with the machine's load than wall
time. It prints each figure per run and their range; nothing is asserted (the targets: written in
under 5 s, under 5 MB, sorted in under 200 ms). Times are wall time on this machine and move
with its load.
"""

from __future__ import annotations

import argparse
import importlib
import json
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bt_servicesim.cli import OneLineArgumentParser
from bt_servicesim.evaluation.html_report import write_html_report
from bt_servicesim.evaluation.node_tables import profile_tables
from bt_servicesim.evaluation.settings import EvaluationSettings
from bt_servicesim.records.profile import Booking, build_profile
from bt_servicesim.records.tree_log import TickRecord
from bt_servicesim.tree.shape import TreeShape

CHECKPOINTS = ("go_to_pick_up", "pick_up_guest", "drop_off_guest", "return_to_start")
LEAVES = ("RequestNewTask", "WaitForLocalisationAndMap", "GetPickUpArea", "NavigateToGoal",
          "NavigateIntoPickUpArea", "GuestSteadilyInRangeHere", "CallPickUpGuest",
          "GetDropOffArea", "NavigateToGoal", "LetGuestCatchUp", "CallDropOffGuest",
          "NavigateToGoal")
"""The running leaves of a real mission, in the order they run (a dozen tip changes)."""
NODES = 130
PHASES = ("BeginTask", "Pickup", "Dropoff", "Return")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(prog="benchmarks/report_html.py",
                                   description="Cost of the evaluation's report.html.")
    parser.add_argument("--episodes", type=int, default=1000, help="episodes in all")
    parser.add_argument("--runs", type=int, default=3, help="rounds of writing and opening")
    parser.add_argument("--log-lines", type=int, default=2500,
                        help="tick lines in each tree log")
    parser.add_argument("--keep", type=Path, help="make the evaluation here and keep it; a "
                        "directory an earlier run kept is used again as it is")
    return parser


def node_keys() -> list[str]:
    """130 keys in pre-order: a root, four phases, each with sequences of leaves."""
    keys = ["Mission"]
    for phase in PHASES:
        keys.append(f"Mission.{phase}")
        for group in range((NODES - 1) // len(PHASES) // 8):
            keys.append(f"Mission.{phase}.Step{group}")
            keys += [f"Mission.{phase}.Step{group}.{leaf}{number}"
                     for number, leaf in enumerate(LEAVES[:6])]
    while len(keys) < NODES:
        keys.append(f"Mission.Return.Extra{len(keys)}")
    return keys


def tree_header() -> dict[str, Any]:
    """The tree log's first line: the 130 nodes, each under the longest key it extends."""
    keys = node_keys()
    index = {key: number for number, key in enumerate(keys)}
    return {"kind": "tree", "version": 1, "tree_file": "trees/servicesim_mission.xml",
            "phases": "Mission",
            "nodes": [{"key": key, "label": key.rsplit(".", 1)[-1],
                       "kind": "behaviour" if key.count(".") == 3 else "sequence",
                       "memory": True, "parent": index.get(key.rsplit(".", 1)[0])
                       if "." in key else None} for key in keys]}


def tick_lines(*, lines: int, end_s: float) -> list[dict[str, Any]]:
    """The tick lines of a mission that runs a dozen leaves one after the other."""
    leaves = [key for key in node_keys() if key.count(".") == 3]
    ticks = []
    for tick in range(1, lines + 1):
        time_s = round(end_s * tick / lines, 1)
        tip = leaves[min(len(leaves) - 1, (tick * 12) // lines * (len(leaves) // 12))]
        ticks.append({"kind": "tick", "tick": tick, "sim_time_s": time_s, "root": "RUNNING",
                      "tip": tip, "nodes": {tip: ["RUNNING", f"{time_s:.1f} sim s, path 12.3 m"]},
                      "blackboard": {"/robot_pose": f"({time_s:.2f}, 3.21, 0.5)"}})
    return ticks


def profile_of(header: dict[str, Any], ticks: list[dict[str, Any]], *,
               points: float) -> dict[str, Any]:
    """The profile the run would write: built by the profile's own code, with points booked
    near walkers at every other second of the mission's middle half."""
    end = ticks[-1]["sim_time_s"]
    times = [end / 4 + step for step in range(0, int(end / 2), 2)]
    bookings = [Booking(sim_time_s=time, sums={
        "approximation/walker/human_3": points * (number + 1) / len(times) * 0.7,
        "approximation/idler/human_9": points * (number + 1) / len(times) * 0.3})
        for number, time in enumerate(times)]
    return build_profile(shape=TreeShape.from_json(header["nodes"]), phases=header["phases"],
                         records=[TickRecord.from_json(line) for line in ticks],
                         bookings=bookings, end_s=end, tree_file=header["tree_file"])


def write_episode(run_dir: Path, *, executive: str, scenario: str, episode: int,
                  log_lines: int, picture: bytes) -> dict[str, Any]:
    run_dir.mkdir(parents=True)
    completed = (episode * 7 + len(executive)) % 5 != 0
    seed = None if scenario == "default" else episode
    durations = [30.0 + episode % 40, 1.0, 50.0 + episode % 30, 60.0 + episode % 20]
    score = 600.0 + (episode * 37 % 900) + (200.0 if executive == "baseline" else 0.0)
    row = {
        "status": "completed" if completed else "failed", "run_id": f"bench-{episode}",
        "seed": seed, "world": "default", "executive": executive, "ros_domain_id": 7,
        "attached": False, "clock": "sim", "timing": "lockstep",
        "reproduce": f"python -m bt_servicesim.run{'' if seed is None else f' --seed {seed}'}"
                     f" --tree trees/servicesim_mission.xml --executive {executive} --speed 0 "
                     "--time-limit 900",
        "completed": completed, "referee_heard": True, "score": score,
        "sim_time_s": sum(durations),
        "checkpoints": [{"name": name, "done": completed or index < 2,
                         "sim_time_s": duration}
                        for index, (name, duration) in enumerate(zip(CHECKPOINTS, durations,
                                                                     strict=True))],
        "penalties": {"failed_pickup": int(not completed), "failed_dropoff": 0,
                      "too_fast": 0, "drifts": episode % 2, "contact": 0.0,
                      "approximation": score - 500.0},
        "wall_time_s": 20.0, "exit_code": 0 if completed else 1,
        "failure": None if completed else "the mission time limit ran out",
        "last_activity": None if completed else "Pickup: NavigateToGoal: 12 m to go",
        "ticks": log_lines, "lockstep_stalls": 0, "lockstep_dropped": None,
        "not_run": False, "scenario": scenario, "episode": episode, "episode_seed": seed,
        "returncode": 0, "episode_wall_time_s": 21.0, "out": str(run_dir),
        "revision": "commit `bench`", "kinematic_bound_s": 120.0,
        "kinematic_bound_legs": [{"checkpoint": name, "bound_s": 30.0} for name in CHECKPOINTS],
        "time_over_bound": round(sum(durations) / 120.0, 4) if completed else None,
    }
    (run_dir / "report.json").write_text(json.dumps(row, indent=2))
    if executive == "bt":
        header = tree_header()
        ticks = tick_lines(lines=log_lines, end_s=sum(durations))
        (run_dir / "tree_log.jsonl").write_text(
            "\n".join(json.dumps(line) for line in [header, *ticks]) + "\n")
        profile = profile_of(header, ticks, points=score - 500.0)
        (run_dir / "profile.json").write_text(json.dumps(profile, indent=1))
    if not completed:
        (run_dir / "trajectory.png").write_bytes(picture)
    return row


def make_evaluation(out: Path, *, episodes: int, log_lines: int) -> tuple[EvaluationSettings,
                                                                          list[dict[str, Any]]]:
    from PIL import Image

    picture_path = out / "picture.png"
    out.mkdir(parents=True, exist_ok=True)
    Image.new("RGB", (320, 240), (40, 90, 160)).save(picture_path)
    picture = picture_path.read_bytes()
    settings = _settings(out, episodes)
    executives, scenarios, per_set = settings.executives, settings.scenarios, settings.episodes
    rows = [write_episode(out / executive / scenario / str(episode), executive=executive,
                          scenario=scenario, episode=episode, log_lines=log_lines,
                          picture=picture)
            for scenario in scenarios for executive in executives for episode in range(per_set)]
    return settings, rows


def _settings(out: Path, episodes: int) -> EvaluationSettings:
    executives, scenarios = ("bt", "baseline"), ("default", "random")
    per_set = max(1, episodes // (len(executives) * len(scenarios)))
    return EvaluationSettings(
        episodes=per_set, scenarios=scenarios, executives=executives, jobs=2, seed=0, out=out,
        speed=0.0, episode_timeout_s=600.0, time_limit_s=900.0, docs=None,
        command_line=f"python -m bt_servicesim.evaluate --episodes {per_set} --out {out}")


def browser_figures(page: Path, profile: Path) -> tuple[float, float, list[list[float]]]:
    """First contentful paint and load (ms from the navigation's start), and the two sorts,
    each as (sorted and laid out, next frame drawn) in ms."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(shutil.which("chromium"))
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1300,1000",
                     f"--user-data-dir={profile}", "--no-first-run", "--disable-extensions"):
        options.add_argument(argument)
    driver = webdriver.Chrome(service=Service(executable_path=str(shutil.which("chromedriver"))),
                              options=options)
    try:
        driver.get(page.as_uri())
        paint, load = driver.execute_script(
            "const p = performance.getEntriesByName('first-contentful-paint')[0];"
            "const n = performance.getEntriesByType('navigation')[0];"
            "return [p ? p.startTime : null, n.loadEventEnd];")
        sorts = [driver.execute_async_script(
            "const done = arguments[arguments.length - 1];"
            "const button = document.querySelector('#episodes th[data-key=score] button');"
            "const start = performance.now(); button.click(); document.body.offsetHeight;"
            "const laid = performance.now() - start;"
            "requestAnimationFrame(() => setTimeout(() =>"
            "  done([laid, performance.now() - start])));")
            for _ in range(2)]
        return paint, load, sorts
    finally:
        driver.quit()


def spread(values: list[float], unit: str, digits: int = 0) -> str:
    return (f"median {statistics.median(values):.{digits}f} {unit}, range "
            f"{min(values):.{digits}f}-{max(values):.{digits}f} {unit}")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.episodes < 4 or args.runs < 1 or args.log_lines < 1:
        print("benchmarks/report_html.py: --episodes must be 4 or more, --runs and "
              "--log-lines 1 or more", file=sys.stderr)
        return 2
    if shutil.which("chromium") is None or shutil.which("chromedriver") is None:
        print("benchmarks/report_html.py: chromium and chromedriver are needed (make test "
              "installs Debian's chromium and chromium-driver)", file=sys.stderr)
        return 2
    importlib.import_module("scipy.stats")  # the evaluation's statistics import it first

    with tempfile.TemporaryDirectory(prefix="report-html-") as temporary:
        out = args.keep or Path(temporary) / "evaluation"
        started = time.perf_counter()
        kept = out / "rows.json"
        if kept.is_file():
            settings, rows = _settings(out, len(json.loads(kept.read_text()))), json.loads(
                kept.read_text())
            print(f"{len(rows)} synthetic episodes kept in {out}")
        else:
            settings, rows = make_evaluation(out, episodes=args.episodes,
                                             log_lines=args.log_lines)
            kept.write_text(json.dumps(rows))
            print(f"{len(rows)} synthetic episodes, {args.log_lines} tick lines per tree log, "
                  f"made in {time.perf_counter() - started:.1f} s in {out}")
        started = time.perf_counter()
        profiles = profile_tables(rows, settings.executives)
        print(f"the evaluation's profile tables (not the page's): "
              f"{time.perf_counter() - started:.2f} s")
        written, cpu, sizes, paints, loads, laid, drawn = [], [], [], [], [], [], []
        for number in range(args.runs):
            started, cpu_started = time.perf_counter(), time.process_time()
            page = write_html_report(settings, rows, revision="commit `bench`",
                                     profiles=profiles)
            written.append(time.perf_counter() - started)
            cpu.append(time.process_time() - cpu_started)
            sizes.append(page.stat().st_size / 1e6)
            paint, load, sorted_ms = browser_figures(page, Path(temporary) / f"chromium-{number}")
            paints.append(paint)
            loads.append(load)
            laid += [figures[0] for figures in sorted_ms]
            drawn += [figures[1] for figures in sorted_ms]
            print(f"run {number + 1}: written {written[-1]:.2f} s ({cpu[-1]:.2f} s CPU), "
                  f"{sizes[-1]:.2f} MB; first contentful paint {paint:.0f} ms, load {load:.0f} "
                  f"ms; sort by score, ascending then descending: laid out "
                  f"{sorted_ms[0][0]:.0f} and {sorted_ms[1][0]:.0f} ms, next frame "
                  f"{sorted_ms[0][1]:.0f} and {sorted_ms[1][1]:.0f} ms")
        print(f"written: {spread(written, 's', 2)}; CPU {spread(cpu, 's', 2)} (target < 5 s)")
        print(f"size: {spread(sizes, 'MB', 2)} (target < 5 MB)")
        print(f"first contentful paint: {spread(paints, 'ms')}; load: {spread(loads, 'ms')}")
        print(f"sort, sorted and laid out: {spread(laid, 'ms')}; to the next frame drawn: "
              f"{spread(drawn, 'ms')} (target < 200 ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
