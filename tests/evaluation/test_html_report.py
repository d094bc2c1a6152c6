"""The evaluation's report.html and a run's, opened in headless Chromium as a person would.

The evaluation is a small synthetic one (``report_fixture.py``: the files episodes leave,
written by the evaluation's own ``write_results``); the browser is Debian's Chromium driven
through Selenium (``browser.py``), installed by ``make test``: a machine without it fails
here, it does not skip.
"""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from selenium.webdriver.support.wait import WebDriverWait

from bt_servicesim.records.episode_view import episode_view
from bt_servicesim.records.html_report import HTML_NAME, write_run_report
from tests.evaluation.browser import console_errors, headless_chromium, missing
from tests.evaluation.report_fixture import make_evaluation

EPISODES = 3
TOTAL = EPISODES * 2 * 2  # two executives, two sets


@pytest.fixture(scope="module")
def evaluation(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[dict[str, Any]]]:
    out = tmp_path_factory.mktemp("evaluation")
    from bt_servicesim.evaluation import kinematic_bound
    from tests.evaluation.bound_fakes import fake_bound_command

    with pytest.MonkeyPatch.context() as patch:  # the module's fixture outlives the autouse one
        patch.setattr(kinematic_bound, "BOUND_COMMAND", fake_bound_command("/dev/null"))
        _, rows = make_evaluation(out, episodes=EPISODES)
    return out, rows


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    problem = missing()
    assert problem is None, problem  # make test installs the browser: never skipped
    with headless_chromium(tmp_path_factory.mktemp("chromium")) as driver:
        yield driver


def _open(browser: Any, page: Path) -> None:
    browser.get(page.as_uri())
    console_errors(browser)  # the log since the last page is not this page's


def test_the_page_is_self_contained(evaluation: tuple[Path, list[dict[str, Any]]]) -> None:
    out, _ = evaluation
    text = (out / HTML_NAME).read_text()
    fetched = re.findall(r'(?:src|href)\s*=\s*"([^"]*)"|url\(([^)]*)\)|@import', text)
    assert fetched and all("//" not in "".join(found) for found in fetched)  # nothing remote
    assert "<script src" not in text and "<link" not in text
    assert text.count('role="img" aria-label=') >= 4  # the plots, inline SVG
    assert "bt/default/2/trajectory.png" in text  # a picture stays a file, linked relatively
    assert (out / "bt/default/2/trajectory.png").is_file()


def test_the_summary_reads_without_scripts(evaluation: tuple[Path, list[dict[str, Any]]],
                                           browser: Any) -> None:
    out, _ = evaluation
    browser.execute_cdp_cmd("Emulation.setScriptExecutionDisabled", {"value": True})
    try:
        browser.get((out / HTML_NAME).as_uri())
        summary = browser.find_element("id", "summary").text
    finally:
        browser.execute_cdp_cmd("Emulation.setScriptExecutionDisabled", {"value": False})
    assert "bt" in summary and "baseline" in summary
    assert "67% (" in summary  # bt completed 2 of 3 per set, with its interval


def test_every_episode_is_a_row_and_sorting_by_score_orders_them(
        evaluation: tuple[Path, list[dict[str, Any]]], browser: Any) -> None:
    out, rows = evaluation
    _open(browser, out / HTML_NAME)
    table = browser.find_element("id", "episodes")
    assert len(table.find_elements("css selector", "tbody tr")) == TOTAL
    score_heading = table.find_element("css selector", 'th[data-key="score"] button')
    score_heading.click()
    shown = _scores(table)
    assert shown == sorted(row["score"] for row in rows)
    score_heading.click()
    assert _scores(table) == sorted(shown, reverse=True)
    assert console_errors(browser) == []


def _scores(table: Any) -> list[float]:
    column = [cell.get_attribute("data-key") for cell in
              table.find_elements("css selector", "thead th")].index("score")
    return [float(row.find_elements("css selector", "td")[column].text)
            for row in table.find_elements("css selector", "tbody tr")]


def test_filtering_hides_the_other_rows(evaluation: tuple[Path, list[dict[str, Any]]],
                                        browser: Any) -> None:
    out, rows = evaluation
    _open(browser, out / HTML_NAME)
    browser.execute_script(
        "const s = document.querySelector('[data-filter=completed]'); s.value = 'no';"
        "s.dispatchEvent(new Event('input', {bubbles: true}));")
    visible = browser.execute_script(
        "return [...document.querySelectorAll('#episodes tbody tr')].filter(r => !r.hidden)"
        ".length")
    assert visible == sum(not row["completed"] for row in rows)
    assert console_errors(browser) == []


def test_an_episode_opens_with_its_picture_and_timeline(
        evaluation: tuple[Path, list[dict[str, Any]]], browser: Any) -> None:
    out, _ = evaluation
    _open(browser, out / HTML_NAME)
    failed = browser.find_element(
        "xpath", "//table[@id='episodes']//tr[td[1]='bt' and td[2]='default' and td[4]='no']")
    failed.send_keys("\n")  # the keyboard opens it as a click does
    dialog = browser.find_element("id", "episode")
    assert dialog.get_attribute("open") is not None
    picture = dialog.find_element("css selector", "img")
    loaded = WebDriverWait(browser, 30).until(lambda driver: driver.execute_script(
        "return arguments[0].complete && arguments[0].naturalWidth", picture))
    assert loaded == 64  # the fixture's 64 x 48 picture, from its relative link
    leaves = dialog.find_elements("css selector", ".timeline rect")
    assert len(leaves) >= 3  # a checkpoint leg and the two leaves that ran
    commands = dialog.text
    assert "python -m bt_servicesim.run --executive bt" in commands
    assert "bt_servicesim.replay" in commands and "run.mcap" not in commands.split("Commands")[0]
    assert console_errors(browser) == []


def test_the_heat_map_is_drawn_and_follows_the_measure(
        evaluation: tuple[Path, list[dict[str, Any]]], browser: Any) -> None:
    out, _ = evaluation
    _open(browser, out / HTML_NAME)
    maps = browser.find_elements("css selector", ".heat")
    assert len(maps) == 2 and not maps[1].is_displayed()  # bt's tree in each set, one shown
    nodes = maps[0].find_elements("css selector", "li")
    assert len(nodes) == 5  # the fixture tree: Mission, two phases, a leaf each
    colours = [node.value_of_css_property("background-color") for node in nodes]
    assert len(set(colours)) > 1
    browser.execute_script(
        "const s = document.getElementById('heat-measure'); s.value = 'running_s';"
        "s.dispatchEvent(new Event('change'));")
    assert [node.value_of_css_property("background-color") for node in nodes] != colours
    browser.execute_script("arguments[0].focus()", nodes[-1])
    assert "GoDropoff" in maps[0].find_element("css selector", "aside").text
    assert "share of the sim time it was RUNNING" in maps[0].text
    browser.execute_script(
        "const s = document.getElementById('heat-tree'); s.value = '1';"
        "s.dispatchEvent(new Event('change'));")
    assert maps[1].is_displayed() and not maps[0].is_displayed()
    assert console_errors(browser) == []


def test_a_run_has_its_own_page(evaluation: tuple[Path, list[dict[str, Any]]],
                                browser: Any) -> None:
    out, _ = evaluation
    run_dir = out / "bt" / "random" / "2"
    page = write_run_report(run_dir, json.loads((run_dir / "report.json").read_text()))
    assert page == run_dir / HTML_NAME
    _open(browser, page)
    assert "Did not complete" in browser.find_element("id", "run").text
    assert browser.find_elements("css selector", "#episode-view .timeline rect")
    assert console_errors(browser) == []


def test_the_timeline_comes_from_the_tree_log(
        evaluation: tuple[Path, list[dict[str, Any]]]) -> None:
    out, _ = evaluation
    run_dir = out / "bt" / "default" / "0"
    report = json.loads((run_dir / "report.json").read_text())
    timeline = episode_view(run_dir, report, link_base=out)["timeline"]
    names = [timeline["names"][index].rsplit(".", 1)[-1] for _, _, index in timeline["leaves"]]
    assert names == ["GoPickup", "GoDropoff"]
    first, second = timeline["leaves"]
    assert first[:2] == [2.5, 15.0]  # ticks 1 to 6, 2.5 s each; the next leaf starts at 6
    assert second[0] == 15.0 and second[1] == timeline["end"]
    assert [leg[2] for leg in timeline["legs"]] == ["go_to_pick_up", "pick_up_guest",
                                                    "drop_off_guest", "return_to_start"]
    assert [phase for _, _, phase in timeline["phases"]] == ["Pickup", "Dropoff"]
    assert [booking[:2] for booking in timeline["bookings"]] == [
        [6.0, "approximation/walker"], [20.0, "approximation/walker"]]


def test_a_run_recorded_without_a_profile_shows_its_tree_log(
        evaluation: tuple[Path, list[dict[str, Any]]], tmp_path: Path) -> None:
    out, _ = evaluation
    run_dir = tmp_path / "run"
    shutil.copytree(out / "bt" / "default" / "0", run_dir)
    report = json.loads((run_dir / "report.json").read_text())
    profiled = episode_view(run_dir, report, link_base=run_dir)["timeline"]
    (run_dir / "profile.json").unlink()
    scanned = episode_view(run_dir, report, link_base=run_dir)["timeline"]
    assert scanned["leaves"] == profiled["leaves"] and scanned["names"] == profiled["names"]
    assert scanned["phases"] == profiled["phases"]
    assert scanned["bookings"] is None and "no profile.json" in scanned["why_no_bookings"]
