// The pumpcyl designer (docs/serve.md). The page computes nothing of its own: each answer is a
// command of the command line asked through /api/COMMAND?set=KEY=VALUE…, its document shown.
// The state is the rig's changed keys, kept in the URL (#kp=30&mass_kg=4898).
"use strict";

const $ = (s) => document.querySelector(s);
const SLIDERS = ["kp", "mass_kg", "beta_bar", "x0_mm"];
const state = { fields: [], base: {}, values: {}, generation: 0 };

// `pumpcyl rig`'s commented TOML: groups (`# --- name ---`), then `key = value  # unit, what`.
function parseRig(text) {
  const fields = [];
  let group = "rig";
  for (const line of text.split("\n")) {
    const g = line.match(/^# --- (.*) ---$/);
    if (g) { group = g[1]; continue; }
    const f = line.match(/^([a-z0-9_]+) = (.*?)(?:\s+#\s*(.*))?$/);
    if (f) fields.push({ group, key: f[1], value: f[2], about: f[3] || "" });
  }
  return fields;
}

// The assignments: every key whose value differs from the served rig's, the circuit first.
function assignments() {
  return state.fields
    .filter((f) => state.values[f.key] !== state.base[f.key])
    .map((f) => `${f.key}=${unquote(state.values[f.key])}`);
}

const unquote = (v) => v.replace(/^"(.*)"$/, "$1");

function query(sets, opts = []) {
  const p = new URLSearchParams();
  for (const s of sets) p.append("set", s);
  for (const o of opts) p.append("opt", o);
  return p.toString();
}

async function ask(command, sets, opts) {
  const r = await fetch(`/api/${command}?${query(sets, opts)}`);
  const body = await r.text();
  if (!r.ok) throw new Error(`${command}: ${JSON.parse(body).error}`);
  return body;
}

// The served rig's own circuit, asked once: the page's circuit is an assignment where it differs.
let servedCircuit = null;

// The fields of `circuit` (the served rig's when none): its keys and defaults, the page's
// changes to keys it shares with the previous circuit kept.
async function loadRig(circuit) {
  if (servedCircuit === null) {
    servedCircuit = parseRig(await ask("rig", [])).find((f) => f.key === "circuit").value;
  }
  const chosen = circuit ? `"${circuit}"` : servedCircuit;
  const sets = chosen === servedCircuit ? [] : [`circuit=${unquote(chosen)}`];
  const fields = parseRig(await ask("rig", sets));
  const kept = state.values;
  state.fields = fields;
  state.base = Object.fromEntries(fields.map((f) => [f.key, f.value]));
  state.base.circuit = servedCircuit;
  state.values = { ...state.base, circuit: chosen };
  for (const [k, v] of Object.entries(kept)) {
    if (k in state.base && k !== "circuit") state.values[k] = v;
  }
  buildForm();
}

function buildForm() {
  const form = $("#rig");
  form.textContent = "";
  const groups = {};
  for (const f of state.fields) {
    if (f.key === "circuit") continue;
    if (!groups[f.group]) {
      const fs = document.createElement("fieldset");
      fs.innerHTML = `<legend></legend>`;
      fs.querySelector("legend").textContent = f.group;
      groups[f.group] = fs;
      form.appendChild(fs);
    }
    const row = document.createElement("div");
    row.className = "field";
    const id = `field-${f.key}`;
    row.innerHTML = `<label></label><input>`;
    const label = row.querySelector("label");
    label.textContent = f.key;
    label.title = f.about;
    label.htmlFor = id;
    const input = row.querySelector("input");
    input.id = id;
    input.name = f.key;
    input.value = unquote(state.values[f.key]);
    input.addEventListener("input", () => set(f.key, quoted(f, input.value)));
    groups[f.group].appendChild(row);
  }
  buildSliders();
  markChanged();
}

const quoted = (f, v) => (f.value.startsWith('"') ? `"${v}"` : v);

function buildSliders() {
  const box = $("#sliders");
  box.textContent = "";
  for (const key of SLIDERS.filter((k) => k in state.base)) {
    const base = Number(state.base[key]);
    const max = key === "x0_mm" ? Number(state.base.stroke_mm) : 3 * base;
    const row = document.createElement("div");
    row.className = "slider";
    row.innerHTML = `<label></label><input type="range"><output></output>`;
    row.querySelector("label").textContent = key;
    const range = row.querySelector("input");
    range.id = `slider-${key}`;
    range.min = key === "x0_mm" ? 0 : base / 5;
    range.max = max;
    range.step = (max - Number(range.min)) / 1000;
    range.value = Number(state.values[key]);
    row.querySelector("output").textContent = state.values[key];
    range.addEventListener("input", () => {
      row.querySelector("output").textContent = range.value;
      $(`#field-${key}`).value = range.value;
      set(key, range.value);
    });
    box.appendChild(row);
  }
}

function markChanged() {
  for (const f of state.fields) {
    const input = document.getElementById(`field-${f.key}`);
    if (input) input.parentElement.classList.toggle("changed", state.values[f.key] !== state.base[f.key]);
  }
}

let timer = null;
function set(key, value) {
  state.values[key] = value;
  markChanged();
  clearTimeout(timer);
  timer = setTimeout(update, 120);
}

// Ask every command for the current assignments and show the answers; an older round that
// finishes late is dropped.
async function update() {
  const generation = ++state.generation;
  const sets = assignments();
  history.replaceState(null, "", "#" + sets.map((s) => s.split("=").map(encodeURIComponent).join("=")).join("&"));
  $("#export-rig").href = `/api/rig?${query(sets)}`;
  $("#export-m").href = `/export/pumpcyl_rig.m?${query(sets)}`;
  $("#export-fmu").href = `/export/pumpcyl.fmu?${query(sets)}`;
  document.body.dataset.state = "busy";
  $("#status").textContent = "…";
  // each answer on its own: a command a circuit does not have yet (a one-motor circuit's
  // step) is named in the errors and the rest still shown
  const questions = [
    ["margins", () => [], showMargins],
    ["design", () => [], showDesign],
    ["design", () => ["robust"], showEnvelope],
    ["step", () => [], drawStep],
    ["track", () => [`freq-hz=${$("#wave-freq-hz").value}`, `amp-mm=${$("#wave-amp-mm").value}`], showTracking],
    ["poles", () => [], showPoles],
    ["bode", () => ["from-hz=0.01", "to-hz=100", "points-per-decade=60"].concat(envelopeCompare()), drawBode],
    ["bulk-modulus", () => [], drawBeta],
  ];
  // one question at a time, on one connection: each answers in milliseconds; the design's
  // answers come first, since the Bode diagram's envelope is made of their points. A round a
  // newer change has overtaken stops showing anything.
  envelope = null;
  designConditions = [];
  const errors = [];
  for (const [command, opts, show] of questions) {
    let body;
    try {
      body = await ask(command, sets, opts());
    } catch (e) {
      if (generation !== state.generation) return;
      errors.push(String(e.message || e));
      continue;
    }
    if (generation !== state.generation) return;
    try {
      show(command === "bode" ? body : JSON.parse(body));
    } catch (e) {
      errors.push(`${command}: ${e.message || e}`);
    }
  }
  $("#errors").textContent = errors.join("\n");
  $("#status").textContent = sets.length ? sets.join(", ") : "the served rig";
  document.body.dataset.state = "ready";
  document.body.dataset.generation = String(generation);
}

// A number shown rounded and carried whole in a data- attribute (tests and scripts read it).
function row(table, label, attr, value, unit, digits = 4) {
  const tr = document.createElement("tr");
  tr.innerHTML = `<td></td><td></td>`;
  tr.children[0].textContent = label;
  tr.children[1].textContent = value === null || value === undefined ? "∞" : `${Number(value).toPrecision(digits)} ${unit}`;
  table.dataset[attr] = value === null || value === undefined ? "inf" : String(value);
  table.querySelector("tbody").appendChild(tr);
}

function showMargins(m) {
  const t = $("#margins");
  t.querySelector("tbody").textContent = "";
  row(t, "gain margin", "gainMarginDb", m.gain_margin_db, "dB");
  row(t, "phase margin", "phaseMarginDeg", m.phase_margin_deg, "deg");
  row(t, "gain crossover", "gainCrossoverHz", m.gain_crossover_hz, "Hz");
  row(t, "phase crossover", "phaseCrossoverHz", m.phase_crossover_hz, "Hz");
  row(t, "delay margin", "delayMarginS", m.delay_margin_s, "s");
  if (m.disk) row(t, "disk margin α (balanced)", "diskMargin", m.disk.disk_margin, "");
  if (m.sensitivity_peak) row(t, "sensitivity peak M_s", "sensitivityPeak", m.sensitivity_peak.value, "");
  if (m.sampled) {
    const s = m.sampled;
    const at = `as the PLC closes it (${s.plc_rate_hz} Hz, ${s.plc_delay_samples} sample delay)`;
    row(t, `gain margin, ${at}`, "sampledGainMarginDb", s.gain_margin_db, "dB");
    row(t, `phase margin, ${at}`, "sampledPhaseMarginDeg", s.phase_margin_deg, "deg");
  }
  t.dataset.closedLoopStable = String(m.closed_loop_stable);
}

function showTracking(t) {
  const tbl = $("#tracking");
  tbl.querySelector("tbody").textContent = "";
  const m = t.cases[0].metrics;
  row(tbl, "largest error", "maxErrorMm", m.max_error_mm, "mm");
  row(tbl, "RMS error", "rmsErrorMm", m.rms_error_mm, "mm");
  row(tbl, "wave reduction", "waveReduction", m.wave_reduction, "");
}

function showDesign(d) {
  designTargets = d.targets;
  designConditions = (d.conditions || []).filter((c) => c.mode === null);
  const t = $("#design");
  t.querySelector("tbody").textContent = "";
  row(t, "largest Kp (design point)", "kpMax", d.kp_max, "");
  row(t, "recommended Kp (worst case)", "kpRecommended", d.kp_recommended, "");
  row(t, "velocity-loop gain", "kvMaxPerS", d.kv_max_per_s, "1/s");
  const tr = document.createElement("tr");
  tr.innerHTML = `<td colspan="2"></td>`;
  tr.firstChild.textContent = (d.reasons || []).join("; ");
  t.querySelector("tbody").appendChild(tr);
  t.dataset.verdict = d.verdict;
}

// Plot helpers: an SVG panel with axes, ticks and polylines.
function panel(box, xr, yr, { logx = false, xlabel = "", ylabel = "" } = {}) {
  const [x0, y0, w, h] = box;
  const fx = (v) => x0 + (w * ((logx ? Math.log10(v) : v) - (logx ? Math.log10(xr[0]) : xr[0]))) / ((logx ? Math.log10(xr[1]) - Math.log10(xr[0]) : xr[1] - xr[0]));
  const fy = (v) => y0 + h - (h * (v - yr[0])) / (yr[1] - yr[0]);
  let s = `<rect x="${x0}" y="${y0}" width="${w}" height="${h}" fill="none" stroke="#999"/>`;
  for (const t of ticks(yr)) s += `<line x1="${x0}" x2="${x0 + w}" y1="${fy(t)}" y2="${fy(t)}" stroke="#eee"/><text x="${x0 - 4}" y="${fy(t) + 4}" text-anchor="end">${t}</text>`;
  const xt = logx ? decades(xr) : ticks(xr);
  for (const t of xt) s += `<line y1="${y0}" y2="${y0 + h}" x1="${fx(t)}" x2="${fx(t)}" stroke="#eee"/><text x="${fx(t)}" y="${y0 + h + 13}" text-anchor="middle">${t}</text>`;
  s += `<text x="${x0 + w / 2}" y="${y0 + h + 27}" text-anchor="middle">${xlabel}</text>`;
  s += `<text transform="translate(${x0 - 38},${y0 + h / 2}) rotate(-90)" text-anchor="middle">${ylabel}</text>`;
  const line = (xs, ys, color, dash = "") => {
    const pts = xs.map((x, i) => `${fx(x).toFixed(1)},${fy(Math.min(Math.max(ys[i], yr[0]), yr[1])).toFixed(1)}`).join(" ");
    return `<polyline points="${pts}" fill="none" stroke="${color}" stroke-width="1.6" stroke-dasharray="${dash}"/>`;
  };
  return { s, line, fx, fy };
}

function ticks([lo, hi]) {
  const step = Math.pow(10, Math.floor(Math.log10((hi - lo) / 4)));
  const k = (hi - lo) / step > 20 ? 5 * step : (hi - lo) / step > 8 ? 2 * step : step;
  const out = [];
  for (let t = Math.ceil(lo / k) * k; t <= hi + 1e-9; t += k) out.push(Number(t.toPrecision(6)));
  return out;
}

const decades = ([lo, hi]) => {
  const out = [];
  for (let e = Math.ceil(Math.log10(lo)); e <= Math.log10(hi); e++) out.push(Number(Math.pow(10, e).toPrecision(3)));
  return out;
};

const range = (a, pad = 0.05) => {
  const lo = Math.min(...a), hi = Math.max(...a), d = (hi - lo) || 1;
  return [lo - pad * d, hi + pad * d];
};

let designTargets = null;

// The envelope (docs/serve.md#envelopes): the design method's stroke and load points, and the
// robust design's worst points over the region of β, b and c12 (`pumpcyl design --robust`),
// each a variant of the Bode diagram at the page's gain.
let envelope = null;
let designConditions = [];

function showEnvelope(robust) {
  const w = robust.worst_case;
  // the point's keys that the circuit has (the valve has no pump leakages)
  const point = (at) => Object.entries({ ...at, x0_mm: at.x_mm })
    .filter(([k, v]) => k in state.base && k !== "mass_by_position" && v !== null)
    .map(([k, v]) => `${k}=${v}`)
    .join(",");
  const words = (at) => `x ${at.x_mm} mm, m ${at.mass_kg} kg, β ${Number(at.beta_bar).toPrecision(4)} bar, ` +
    `c12 ${Number(at.c12_m5_per_ns).toPrecision(3)}, b ${Number(at.viscous_friction_ns_per_m).toPrecision(3)} N·s/m`;
  envelope = {
    worst: [["PM", w.phase_margin_deg.at], ["GM", w.gain_margin_db.at]].map(([k, at]) => ({ k, compare: point(at), words: words(at) })),
  };
  const svg = $("#bode");
  svg.dataset.worstPmAt = envelope.worst[0].words;
  svg.dataset.worstGmAt = envelope.worst[1].words;
  const r = robust.region;
  $("#envelope").textContent = `Envelope: the design's stroke and load points (grey) and the worst points (orange) of the region β ${r.beta_bar.map((v) => v.toPrecision(4)).join("…")} bar, c12 ${r.c12_m5_per_ns.map((v) => v.toPrecision(3)).join("…")} (${r.source}; pumpcyl design --robust), at this gain. Worst phase margin at ${envelope.worst[0].words}; worst gain margin at ${envelope.worst[1].words}.`;
}

function envelopeCompare() {
  const points = designConditions.map((c) => `x0_mm=${c.x_mm},mass_kg=${c.mass_kg},beta_bar=${c.beta_bar}`);
  const worst = envelope ? envelope.worst.map((w) => w.compare) : [];
  return points.concat(worst).map((c) => `compare=${c}`);
}

function drawBode(csv) {
  const targets = designTargets;
  const rows = csv.trim().split("\n").slice(1).map((l) => l.split(",").map(Number));
  const col = (k) => rows.map((r) => r[k]);
  const f = col(0), mag = col(1), ph = col(2);
  const fr = [f[0], f[f.length - 1]];
  const variants = (rows[0].length - 3) / 2;
  const allMag = [], allPh = [];
  for (let k = 0; k <= variants; k++) allMag.push(...col(1 + 2 * k)), allPh.push(...col(2 + 2 * k));
  const m = panel([60, 10, 560, 170], fr, range(allMag.filter(isFinite)), { logx: true, ylabel: "magnitude (dB)" });
  const p = panel([60, 215, 560, 170], fr, range(allPh.filter(isFinite).concat([-180])), { logx: true, xlabel: "frequency (Hz)", ylabel: "phase (deg)" });
  let s = m.s + p.s;
  const worstFrom = variants - (envelope ? envelope.worst.length : 0);
  for (let k = 1; k <= variants; k++) {
    const color = k > worstFrom ? "#D55E00" : "#bbb";
    s += m.line(f, col(1 + 2 * k), color) + p.line(f, col(2 + 2 * k), color);
  }
  s += m.line(f, mag, "#0072B2") + p.line(f, ph, "#0072B2");
  s += m.line(fr, [0, 0], "#555", "3 3") + p.line(fr, [-180, -180], "#555", "3 3");
  if (targets) {
    s += m.line(fr, [-targets.gm_db, -targets.gm_db], "#D55E00", "6 4");
    s += p.line(fr, [-180 + targets.pm_deg, -180 + targets.pm_deg], "#D55E00", "6 4");
  }
  $("#bode").innerHTML = s;
}

function drawStep(step) {
  const t = step.signals.time_s, x = step.signals.x_mm, r = step.signals.x_ref_mm;
  const p = panel([60, 10, 560, 190], [t[0], t[t.length - 1]], range(x.concat(r)), { xlabel: "time (s)", ylabel: "position (mm)" });
  $("#step").innerHTML = p.s + p.line(t, r, "#999", "4 3") + p.line(t, x, "#0072B2");
  const svg = $("#step");
  svg.dataset.riseTimeS = String(step.metrics.rise_time_s);
  svg.dataset.overshootPct = String(step.metrics.overshoot_pct);
}

function drawBeta(bulk) {
  const pts = bulk.table;
  const p = pts.map((r) => r.p_bar), b = pts.map((r) => r.beta_bar);
  const pl = panel([60, 10, 560, 190], range(p, 0), range(b), { xlabel: "mean chamber pressure (bar)", ylabel: "β_e (bar)" });
  let s = pl.s + pl.line(p, b, "#0072B2");
  const at = bulk.gas_fraction_from;
  if (at && at.p_mean_bar !== null && at.p_mean_bar !== undefined) {
    s += `<circle cx="${pl.fx(at.p_mean_bar)}" cy="${pl.fy(at.beta_bar)}" r="5" fill="#D55E00"/>`;
  }
  $("#beta").innerHTML = s;
  $("#beta").dataset.gasFraction = String(bulk.gas_fraction);
}

function showPoles(poles) {
  const body = $("#poles tbody");
  body.textContent = "";
  for (const p of poles.closed_loop || []) {
    const tr = document.createElement("tr");
    for (const v of [p.re, p.im, p.natural_freq_hz, p.damping]) {
      const td = document.createElement("td");
      td.textContent = Number(v).toPrecision(4);
      tr.appendChild(td);
    }
    body.appendChild(tr);
  }
}

// The URL's state: #key=value&… (the page's assignments), read at start.
function fromHash() {
  const out = {};
  for (const part of location.hash.replace(/^#/, "").split("&").filter(Boolean)) {
    const [k, v] = part.split("=").map(decodeURIComponent);
    out[k] = v;
  }
  return out;
}

async function start() {
  try {
    const wanted = fromHash();
    await loadRig(wanted.circuit);
    $("#circuit").value = unquote(state.values.circuit);
    for (const [k, v] of Object.entries(wanted)) {
      if (k === "circuit" || !(k in state.base)) continue;
      const f = state.fields.find((x) => x.key === k);
      state.values[k] = quoted(f, v);
      const input = document.getElementById(`field-${k}`);
      if (input) input.value = v;
      const slider = document.getElementById(`slider-${k}`);
      if (slider) {
        slider.value = v;
        slider.parentElement.querySelector("output").textContent = v;
      }
    }
    markChanged();
    for (const id of ["#wave-freq-hz", "#wave-amp-mm"]) {
      $(id).addEventListener("input", () => { clearTimeout(timer); timer = setTimeout(update, 120); });
    }
    $("#circuit").addEventListener("change", async () => {
      await loadRig($("#circuit").value);
      update();
    });
    await update();
  } catch (e) {
    $("#errors").textContent = String(e.message || e);
    document.body.dataset.state = "ready";
  }
}

start();
