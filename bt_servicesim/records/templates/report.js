// The report's behaviour: sorting and filtering the episodes, an episode's view (its picture,
// its timeline, its penalties and commands) and the heat map's choices. Plain DOM, no library:
// the page must open from the file system with no network.
"use strict";
(function () {
  const data = JSON.parse(document.getElementById("report-data").textContent);
  const episodes = data.episodes;
  const S = data.strings;  // every name in the timelines, once
  const SVG = "http://www.w3.org/2000/svg";

  function el(tag, attributes, ...children) {
    const node = tag.startsWith("svg:") ? document.createElementNS(SVG, tag.slice(4))
      : document.createElement(tag);
    for (const [name, value] of Object.entries(attributes || {})) {
      if (value !== null && value !== undefined) node.setAttribute(name, value);
    }
    for (const child of children) {
      if (child !== null && child !== undefined) {
        node.append(typeof child === "string" ? document.createTextNode(child) : child);
      }
    }
    return node;
  }
  const fixed = (value, digits) => value === null || value === undefined ? "–"
    : Number(value).toFixed(digits);
  const words = (text) => String(text).replace(/_/g, " ");

  // ------------------------------------------------------------------------ copy buttons
  function wireCopy(root) {
    for (const button of root.querySelectorAll("button.copy")) {
      button.hidden = false;
      button.addEventListener("click", () => {
        const text = button.previousElementSibling.textContent;
        const done = () => { button.textContent = "Copied"; setTimeout(() => { button.textContent = "Copy"; }, 1500); };
        if (navigator.clipboard) {
          navigator.clipboard.writeText(text).then(done, () => selectText(button.previousElementSibling));
        } else {
          selectText(button.previousElementSibling);
        }
      });
    }
  }
  function selectText(node) {
    const range = document.createRange();
    range.selectNodeContents(node);
    const selection = window.getSelection();
    selection.removeAllRanges();
    selection.addRange(range);
  }
  function commandBlock(text, label) {
    const block = el("div", { class: "command" }, el("pre", { "aria-label": label }, text),
      el("button", { type: "button", class: "copy" }, "Copy"));
    return block;
  }

  // ------------------------------------------------------------------------ the timeline
  const COLOURS = ["#4e79a7", "#f28e2b", "#59a14f", "#e15759", "#76b7b2", "#edc948",
    "#b07aa1", "#ff9da7", "#9c755f", "#bab0ac"];
  function timelineSvg(timeline) {
    const end = Math.max(timeline.end, 1);
    const width = 900, left = 110, right = 12, laneHeight = 26, gap = 8;
    const lanes = [["checkpoints", timeline.legs.map((leg) => ({ start: leg[0], end: leg[1],
      label: words(S[leg[2]]), detail: leg[3] === null ? "" : `bound ${fixed(leg[3], 1)} s` }))]];
    if (timeline.phases) {
      lanes.push(["tree phase", timeline.phases.map((p) => ({ start: p[0], end: p[1], label: S[p[2]] }))]);
    }
    lanes.push(["running leaf", timeline.leaves.map((s) => ({ start: s[0], end: s[1],
      label: S[s[2]].split(".").pop(), detail: S[s[2]], colour: s[2] }))]);
    const bookingLanes = timeline.bookings && timeline.bookings.length ? 1 : 0;
    const axisY = (lanes.length + bookingLanes) * (laneHeight + gap) + 14;
    const height = axisY + 26;
    const x = (t) => left + (width - left - right) * t / end;
    const svg = el("svg:svg", { viewBox: `0 0 ${width} ${height}`, role: "img",
      "aria-label": "Timeline over sim time: checkpoints, phases, running leaf and penalty bookings" });
    lanes.forEach(([name, stretches], lane) => {
      const y = 4 + lane * (laneHeight + gap);
      svg.append(el("svg:text", { x: 0, y: y + laneHeight * 0.65, class: "lane-label" }, name));
      const colourOf = new Map();
      stretches.forEach((stretch) => {
        const key = stretch.colour !== undefined ? stretch.colour : stretch.label;
        if (!colourOf.has(key)) colourOf.set(key, COLOURS[colourOf.size % COLOURS.length]);
        const w = Math.max(x(stretch.end) - x(stretch.start), 0.5);
        const title = `${stretch.label}: ${fixed(stretch.start, 1)}–${fixed(stretch.end, 1)} s`
          + (stretch.detail ? ` (${stretch.detail})` : "");
        const rect = el("svg:rect", { x: x(stretch.start), y, width: w, height: laneHeight,
          fill: colourOf.get(key), "fill-opacity": 0.85 }, el("svg:title", {}, title));
        svg.append(rect);
        if (w > 46) {
          svg.append(el("svg:text", { x: x(stretch.start) + 3, y: y + laneHeight * 0.65,
            fill: "#fff", "pointer-events": "none" },
            stretch.label.slice(0, Math.floor(w / 6.5))));
        }
      });
      if (!stretches.length) {
        const why = name === "running leaf" ? timeline.why_no_leaves : "no checkpoint booked";
        svg.append(el("svg:text", { x: left, y: y + laneHeight * 0.65, class: "lane-label" }, why || "nothing logged"));
      }
    });
    if (timeline.bookings && timeline.bookings.length) {  // a lane of bars, height by points
      const y = 4 + lanes.length * (laneHeight + gap);
      const top = Math.max(...timeline.bookings.map((b) => b[2]), 1e-9);
      svg.append(el("svg:text", { x: 0, y: y + laneHeight * 0.65, class: "lane-label" }, "points booked"));
      for (const booking of timeline.bookings) {
        const h = Math.max(laneHeight * booking[2] / top, 1.5);
        svg.append(el("svg:rect", { x: x(booking[0]) - 1.5, y: y + laneHeight - h, width: 3, height: h,
          fill: "#b3261e" }, el("svg:title", {}, `${words(S[booking[1]])}: ${fixed(booking[2], 1)} points at ${fixed(booking[0], 1)} s`)));
      }
    }
    svg.append(el("svg:line", { x1: left, x2: width - right, y1: axisY, y2: axisY, stroke: "#59636e" }));
    const step = niceStep(end);
    for (let t = 0; t <= end + 1e-9; t += step) {
      svg.append(el("svg:line", { x1: x(t), x2: x(t), y1: axisY, y2: axisY + 4, stroke: "#59636e" }));
      svg.append(el("svg:text", { x: x(t), y: axisY + 16, "text-anchor": "middle", class: "lane-label" }, `${Math.round(t)} s`));
    }
    return svg;
  }
  function niceStep(end) {
    const raw = end / 8, power = Math.pow(10, Math.floor(Math.log10(raw)));
    return [1, 2, 5, 10].map((m) => m * power).find((s) => s >= raw);
  }

  // ------------------------------------------------------------------------ an episode
  function renderEpisode(ep, container, withHead) {
    container.replaceChildren();
    if (withHead) {
      const seed = ep.seed === null ? "the shipped task" : `seed ${ep.seed}`;
      const close = el("button", { type: "button", class: "close" }, "Close");
      close.addEventListener("click", () => document.getElementById("episode").close());
      container.append(el("div", { class: "episode-head" },
        el("h2", { id: "episode-title" }, `${ep.executive}, ${ep.scenario}, ${seed}`), close));
      const verdict = ep.completed ? "completed" : `did not complete: ${ep.failure || ep.status}`;
      container.append(el("p", { class: ep.completed ? "ok" : "failed" },
        `${verdict}; score ${fixed(ep.score, 1)}, ${fixed(ep.sim_time_s, 1)} s sim`
        + (ep.over_bound === null ? "" : `, ${fixed(ep.over_bound, 2)} × the kinematic bound`)));
      if (ep.last_activity) container.append(el("p", { class: "muted" }, `last: ${ep.last_activity}`));
    }
    container.append(el("h3", {}, "Timeline over sim time"),
      el("div", { class: "timeline" }, timelineSvg(ep.timeline)));
    if (!ep.timeline.bookings) {
      container.append(el("p", { class: "absent" }, `No penalty bookings marked: ${ep.timeline.why_no_bookings}.`));
    }
    const side = el("div", {});
    side.append(el("h3", {}, "Penalties by cause"));
    if (ep.causes) {
      const entries = Object.entries(ep.causes);
      side.append(entries.length ? el("table", {}, el("tbody", {}, ...entries.map(([cause, points]) =>
        el("tr", {}, el("th", {}, words(cause)), el("td", { class: "n" }, fixed(points, 1)))))
      ) : el("p", {}, "No points booked."));
    } else {
      side.append(el("p", { class: "absent" }, "No points by cause: the run has no profile.json."));
    }
    if (withHead) {  // a run's own page lists the referee's totals above
      side.append(el("h3", {}, "Penalties as the referee counted them"),
        el("table", {}, el("tbody", {}, ...Object.entries(ep.penalties).map(([kind, value]) =>
          el("tr", {}, el("th", {}, words(kind)), el("td", { class: "n" }, fixed(value, 2)))))));
    }
    side.append(el("h3", {}, "Commands"));
    const c = ep.commands;
    if (c.replay) side.append(el("p", {}, "Play it again:"), commandBlock(c.replay, "command that plays it again"));
    if (c.step) side.append(el("p", {}, "Step through its tree:"), commandBlock(c.step, "command that steps through its tree"));
    if (c.recording) {
      side.append(el("p", {}, "Open its recording in Foxglove (Open local file):"),
        commandBlock(c.recording, "path of its recording"),
        el("p", {}, el("a", { href: `${ep.dir}/run.mcap` }, "run.mcap")));
    } else {
      side.append(el("p", { class: "absent" }, "No run.mcap in the run directory."));
    }
    const main = el("div", {});
    main.append(el("h3", {}, "Trajectory"));
    if (ep.picture) {
      main.append(el("img", { src: ep.picture, alt: `Trajectory of ${ep.executive}, ${ep.scenario}, episode ${ep.episode}` }));
    } else {
      main.append(el("p", { class: "absent" }, "No trajectory picture: the run drew none (an evaluation draws it for failed episodes). python -m bt_servicesim.trajectory DIR draws it from the recording."));
    }
    container.append(el("div", { class: "episode-body" }, main, side));
    wireCopy(container);
  }

  // ------------------------------------------------------------------------ the table
  function setUpTable() {
    const table = document.getElementById("episodes");
    if (!table) return;
    const body = table.tBodies[0];
    const rows = Array.from(body.rows);
    const dialog = document.getElementById("episode");
    const view = document.getElementById("episode-view");
    const open = (index) => {
      renderEpisode(episodes[index], view, true);
      if (!dialog.open) dialog.showModal();
      history.replaceState(null, "", `#episode=${encodeURIComponent(episodes[index].dir)}`);
    };
    dialog.addEventListener("close", () => history.replaceState(null, "", "#episodes-section"));
    for (const row of rows) {
      row.tabIndex = 0;
      row.addEventListener("click", (event) => { event.preventDefault(); open(Number(row.dataset.i)); });
      row.addEventListener("keydown", (event) => {
        if (event.key === "Enter" || event.key === " ") { event.preventDefault(); open(Number(row.dataset.i)); }
      });
    }
    const value = (episode, key) => key.startsWith("penalties.") ? episode.penalties[key.slice(10)]
      : episode[key];
    for (const heading of table.tHead.rows[0].cells) {
      heading.querySelector("button").addEventListener("click", () => {
        const key = heading.dataset.key;
        const ascending = heading.getAttribute("aria-sort") !== "ascending";
        for (const other of table.tHead.rows[0].cells) other.setAttribute("aria-sort", "none");
        heading.setAttribute("aria-sort", ascending ? "ascending" : "descending");
        const sign = ascending ? 1 : -1;
        const keyed = episodes.map((episode, i) => ({ i, v: value(episode, key) }));
        keyed.sort((a, b) => {
          const x = a.v, y = b.v;
          if (x === y) return a.i - b.i;
          if (x === null || x === undefined) return 1;  // missing values last either way
          if (y === null || y === undefined) return -1;
          return (typeof x === "number" && typeof y === "number" ? x - y
            : String(x).localeCompare(String(y))) * sign;
        });
        body.append(...keyed.map((k) => rows[k.i]));
      });
    }
    const filters = document.getElementById("episode-filters");
    filters.hidden = false;
    const count = document.getElementById("episode-count");
    const apply = () => {
      const chosen = {};
      for (const input of filters.querySelectorAll("[data-filter]")) chosen[input.dataset.filter] = input.value.trim().toLowerCase();
      let shown = 0;
      for (const row of rows) {
        const ep = episodes[row.dataset.i];
        const text = `${ep.seed === null ? "shipped" : ep.seed} ${ep.failure || ""}`.toLowerCase();
        const visible = (!chosen.executive || ep.executive.toLowerCase() === chosen.executive)
          && (!chosen.scenario || String(ep.scenario).toLowerCase() === chosen.scenario)
          && (!chosen.completed || (chosen.completed === "yes") === ep.completed)
          && (!chosen.text || text.includes(chosen.text));
        row.hidden = !visible;
        shown += visible;
      }
      count.textContent = `${shown} of ${rows.length} episodes`;
    };
    filters.addEventListener("input", apply);
    apply();
    const wanted = decodeURIComponent((location.hash.match(/^#episode=(.*)$/) || [])[1] || "");
    const index = episodes.findIndex((ep) => ep.dir === wanted);
    if (index >= 0) open(index);
  }

  // ------------------------------------------------------------------------ the heat map
  function setUpHeat() {
    const heat = data.heat;
    if (!heat || !heat.trees.length) return;
    const measureSelect = document.getElementById("heat-measure");
    const treeSelect = document.getElementById("heat-tree");
    const maps = Array.from(document.querySelectorAll(".heat"));
    const unit = (key) => (heat.measures.find((m) => m.key === key) || {}).unit || "";
    const colour = (share) => {  // white to dark orange, as the legend
      const stops = [[255, 255, 255], [253, 208, 162], [241, 105, 19], [127, 39, 4]];
      const at = Math.min(Math.max(share, 0), 1) * (stops.length - 1);
      const low = Math.floor(at), high = Math.min(low + 1, stops.length - 1), f = at - low;
      const rgb = stops[low].map((c, i) => Math.round(c + (stops[high][i] - c) * f));
      return `rgb(${rgb.join(",")})`;
    };
    const paint = () => {
      const measure = measureSelect.value;
      maps.forEach((map, number) => {
        const nodes = heat.trees[number].nodes;
        const top = Math.max(...nodes.map((n) => n.figures[measure] || 0), 1e-9);
        for (const item of map.querySelectorAll("li")) {
          const node = nodes[item.dataset.node];
          const value = node.figures[measure] || 0;
          const share = value / top;
          item.style.background = colour(share);
          item.style.color = share > 0.6 ? "#fff" : "";
          item.querySelector(".value").textContent = Math.abs(value) >= 0.05 ? `${fixed(value, 1)}${unit(measure)}` : "";
        }
      });
    };
    const show = (map, item) => {
      const node = heat.trees[Number(map.dataset.tree)].nodes[item.dataset.node];
      const aside = map.querySelector("aside");
      aside.replaceChildren(el("h3", {}, node.label), el("p", { class: "muted" }, node.key),
        el("table", {}, el("tbody", {}, ...heat.measures.map((m) => el("tr", {},
          el("th", {}, m.label), el("td", { class: "n" }, `${fixed(node.figures[m.key] || 0, 2)}${m.unit}`))))));
    };
    for (const map of maps) {
      for (const item of map.querySelectorAll("li")) {
        item.addEventListener("mouseenter", () => show(map, item));
        item.addEventListener("focus", () => show(map, item));
      }
    }
    measureSelect.addEventListener("change", paint);
    if (treeSelect) {
      treeSelect.addEventListener("change", () => {
        maps.forEach((map, number) => { map.hidden = String(number) !== treeSelect.value; });
      });
    }
    paint();
  }

  wireCopy(document);
  setUpTable();
  setUpHeat();
  const single = document.querySelector("#run #episode-view");
  if (single) renderEpisode(episodes[0], single, false);
})();
