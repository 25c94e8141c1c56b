// The SDViSC live view: draws the topology once, then applies each server-sent snapshot
// (scenarios/web.py: /live) to the link classes, the T1-T3 table, four uPlot charts and the logs.
"use strict";
const WINDOW_S = 30;          // simulated seconds shown in the plots
const MAX_LOG = 400;          // lines kept in each log
const COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22"];
const PLOTS = [["v", "V (p.u.)"], ["q", "Q (p.u.)"], ["f_hz", "f (Hz)"], ["ctrl_per_s", "control packets/s"]];
const SVG = "http://www.w3.org/2000/svg";
const linkId = (a, b) => [a, b].sort().join("-");

let charts = {}, visc = [], series = {t: []}, colourOf = {};

function el(tag, attrs, parent) {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (parent) parent.appendChild(e);
  return e;
}

function drawTopology(topo) {
  document.getElementById("scenario").textContent = `${topo.scenario} (${topo.topology})`;
  if (topo.time_scale !== 1) document.getElementById("scale").textContent = `(virtual time, k = ${topo.time_scale})`;
  const svg = document.getElementById("topology"), W = 1000, H = 560, pos = {};
  for (const [name, n] of Object.entries(topo.nodes)) pos[name] = [30 + n.x * (W - 60), 20 + n.y * (H - 40)];
  for (const [a, b] of topo.links) {
    el("line", {x1: pos[a][0], y1: pos[a][1], x2: pos[b][0], y2: pos[b][1], "data-link": linkId(a, b),
                id: "link-" + linkId(a, b)}, svg);
  }
  for (const [name, n] of Object.entries(topo.nodes)) {
    const g = el("g", {class: "node " + (n.kind === "switch" ? (n.openflow ? "of" : "l2") : n.kind), "data-node": name}, svg);
    const [x, y] = pos[name];
    if (n.kind === "switch") {
      el("rect", {x: x - 24, y: y - 13, width: 48, height: 26, rx: 6}, g);
      el("text", {x: x, y: y + 5}, g).textContent = name;
    } else {
      el("circle", {cx: x, cy: y, r: 11, class: n.kind}, g);
      el("text", {x: x, y: y + (n.kind === "turbine" ? 28 : -17)}, g).textContent = name;
    }
  }
}

// a flat signal (V = 1.0 on an infinite bus) gets a small band around it, not 0…100
function padded(u, min, max) {
  if (min === null || max === null) return [0, 1];
  const pad = Math.max((max - min) * 0.1, Math.abs(max) * 0.002, 1e-3);
  return [min - pad, max + pad];
}

function makeCharts() {
  for (const c of Object.values(charts)) c.destroy();
  charts = {};
  for (const [key, label] of PLOTS) {
    const box = document.getElementById("plot-" + (key === "f_hz" ? "f" : key === "ctrl_per_s" ? "rate" : key));
    box.innerHTML = "";
    const opts = {
      title: label, width: Math.max(200, box.clientWidth - 4), height: 180,
      scales: {x: {time: false}, y: {range: padded}}, legend: {show: true, live: false},
      axes: [{label: "t (s)", size: 34}, {size: 56}],
      series: [{label: "t"}, ...visc.map(wt => ({label: wt, stroke: colourOf[wt], width: 1.5}))],
    };
    charts[key] = new uPlot(opts, [series.t, ...visc.map(wt => series[wt][key])], box);
  }
}

function updatePlots(snap, redraw = true) {
  const names = Object.keys(snap.turbines).sort();
  for (const wt of names) {
    if (!series[wt]) {
      series[wt] = Object.fromEntries(PLOTS.map(([k]) => [k, series.t.map(() => null)]));
      colourOf[wt] = COLOURS[Object.keys(colourOf).length % COLOURS.length];
    }
  }
  const known = Object.keys(series).filter(k => k !== "t");
  const t = snap.t_sim;
  if (t !== null && t !== undefined && (!series.t.length || t > series.t[series.t.length - 1])) {
    series.t.push(t);
    for (const wt of known) for (const [k] of PLOTS) {
      const row = snap.turbines[wt];
      series[wt][k].push(row && row[k] !== null && row[k] !== undefined ? row[k] : null);
    }
    while (series.t.length && series.t[0] < t - WINDOW_S) {
      series.t.shift();
      for (const wt of known) for (const [k] of PLOTS) series[wt][k].shift();
    }
  }
  if (!redraw) return;
  if (known.join() !== visc.join()) { visc = known; makeCharts(); }
  document.getElementById("visc-list").textContent = names.length ? "(" + names.join(", ") + ")" : "(none now)";
  for (const [k] of PLOTS) charts[k] && charts[k].setData([series.t, ...visc.map(wt => series[wt][k])]);
}

function updateNetwork(snap) {
  for (const line of document.querySelectorAll("#topology line")) {
    line.classList.remove("path", "down");
    line.style.stroke = "";
  }
  for (const [wt, path] of Object.entries(snap.paths)) {
    if (!path) continue;
    for (let i = 0; i + 1 < path.length; i++) {
      const line = document.getElementById("link-" + linkId(path[i], path[i + 1]));
      if (line) { line.classList.add("path"); line.style.stroke = colourOf[wt] || COLOURS[0]; line.dataset.turbine = wt; }
    }
  }
  for (const [a, b] of snap.down_links) {
    const line = document.getElementById("link-" + linkId(a, b));
    if (line) line.classList.add("down");
  }
  for (const g of document.querySelectorAll("#topology g.node")) g.classList.toggle("dead", snap.dead_sdcs.includes(g.dataset.node));
  const down = document.getElementById("down-links");
  down.textContent = "down links: " + (snap.down_links.length ? snap.down_links.map(l => l.join("-")).join(", ") : "–");
  down.classList.toggle("some", snap.down_links.length > 0);
}

function updateTables(snap) {
  const body = document.querySelector("#t123 tbody");
  const rows = Object.keys(snap.T1).sort().map(wt => {
    const a = snap.T1[wt], path = snap.paths[wt];
    const tr = document.createElement("tr");
    tr.id = "row-" + wt;
    if (snap.turbines[wt]) tr.className = "visc";
    const live = snap.turbines[wt] || {};
    const num = (x, digits) => x === null || x === undefined ? "–" : x.toFixed(digits);
    for (const [cls, text] of [["", wt], ["", a.ip], ["", `${a.switch}:${a.port}`], ["", snap.T2[wt] || "?"],
                                ["", snap.T3[wt] || "?"], ["", num(live.ctrl_per_s, 0)], ["", num(live.ctrl_delay_ms, 2)],
                                ["path", path ? path.join("-") : "–"]]) {
      const td = document.createElement("td");
      if (cls) { td.className = cls; td.id = "path-" + wt; }
      td.textContent = text;
      tr.appendChild(td);
    }
    return tr;
  });
  body.replaceChildren(...rows);
}

function appendLog(id, lines, cls) {
  const ol = document.getElementById(id);
  for (const text of lines) {
    const li = document.createElement("li");
    li.textContent = text;
    if (cls && cls(text)) li.className = "bad";
    ol.appendChild(li);
  }
  while (ol.children.length > MAX_LOG) ol.removeChild(ol.firstChild);
  if (lines.length) ol.scrollTop = ol.scrollHeight;
}

function eventText(e) {
  const rest = Object.entries(e).filter(([k]) => !["t", "type", "source"].includes(k))
    .map(([k, v]) => `${k}=${Array.isArray(v) ? v.join(k.endsWith("path") || k === "link" ? "-" : ",") : typeof v === "object" && v !== null ? JSON.stringify(v) : v}`);
  return `${e.t.toFixed(3).padStart(9)} s  ${(e.source || "?").padEnd(9)} ${e.type.padEnd(16)} ${rest.join(" ")}`;
}

function apply(snap) {
  document.getElementById("t").textContent = snap.t_sim !== null && snap.t_sim !== undefined ? snap.t_sim.toFixed(2) : "–";
  document.getElementById("late").textContent = snap.late_steps;
  document.getElementById("active-sdc").textContent = snap.active_sdc || "–";
  for (const point of snap.history || []) updatePlots(point, false);  // what happened before the page opened
  updatePlots(snap);
  updateNetwork(snap);
  updateTables(snap);
  appendLog("feedback", snap.lines, t => /not restored|lost|refused|dead|no path/.test(t) && !/restored after/.test(t));
  appendLog("events", snap.events.map(eventText));
  const state = document.getElementById("state");
  state.textContent = snap.ended ? "session ended" : "live";
  state.className = snap.ended ? "ended" : "live";
}

fetch("/topology.json").then(r => r.json()).then(topo => {
  drawTopology(topo);
  const source = new EventSource("/live");
  source.onmessage = msg => {
    const snap = JSON.parse(msg.data);
    apply(snap);
    if (snap.ended) source.close();
  };
  source.onerror = () => {
    const state = document.getElementById("state");
    if (state.textContent !== "session ended") { state.textContent = "disconnected"; state.className = "ended"; }
  };
});
