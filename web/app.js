// app.js: the page. Reads ?head=&stream=&replay=&algo=&algo2=&heat=&heat2=&heatmax=&heatmax2=&view=&view2=&cut=&cut2=&mouth=&lips=&lipstrength=&token=&nodes=&audio=
// (replay: a recording of the head, played by the server at the viewer's pace with the
// transport bar, replay.js, instead of the live stream; lips: tint, contrast, region or
// off, how both views draw the lips; lipstrength: the tint's strength, 0 to 1)
// (heat=1 colours by roughness, heat=folds by folds; nodes: server base URLs to fail over
// between, nodes.js; audio=opus|pcm|none: the voice's codec, by default Opus where the
// browser decodes it; view: front, side, cutaway or see-through, cut: the cut-away's turn
// from the midsagittal plane in degrees), one sound for both views (sound.js; the Sound button starts it, as
// browsers want a click before a page plays audio; once it plays, the views draw the frame
// being heard),
// fills the pickers from /v1/heads (read again every few seconds, so new heads and streams
// appear) and /v1/algorithms, runs one view or two side by side: each a <facewire-head>
// element (facewire-head.js) in one group (head-group.js: one shared camera, one sound,
// drawn in step, each view decoding only its newest frame). Under them, the chosen
// head's fit report (fit.js), fetched again when the head's status changes. The Talk
// button makes the microphone the producer of the head's `talk` stream (talk.js). "Your
// own head" registers the user's files (upload.js) and shows that head once it is fitted.

import { OrbitCamera } from "./camera.js";
import { LiveChart } from "./chart.js";
import { fitOutcome, fitPaths } from "./fit.js";
import { HeadGroup } from "./head-group.js";
import { Nodes } from "./nodes.js";
import { DEFAULT_HEAT_MAX, Panel } from "./panel.js";
import { ReplayBar } from "./replay.js";
import { audioCodec, Sound } from "./sound.js";
import { LIP_MODES } from "./render.js";
import { Talk } from "./talk.js";
import { idFromFileName, registerHead, sourceSummary } from "./upload.js";

/** The stream the Talk button produces (the microphone, `derive=visemes`). */
const TALK_STREAM = "talk";
/** How often the head and stream lists are read again. */
const LIST_REFRESH_MS = 5000;

const byId = (id) => document.getElementById(id);
const controls = {
  head: byId("head"),
  stream: byId("stream"),
  compare: byId("compare"),
  zoomIn: byId("zoom-in"),
  zoomOut: byId("zoom-out"),
  resetView: byId("reset-view"),
  mouthView: byId("mouth-view"),
  lips: byId("lips"),
  lipStrength: byId("lip-strength"),
  sound: byId("sound"),
  talk: byId("talk"),
  volume: byId("volume"),
  views: byId("views"),
  message: byId("page-message"),
};
/** "Your own head" (index.html). */
const upload = {
  form: byId("upload-form"),
  files: byId("upload-files"),
  id: byId("upload-id"),
  token: byId("upload-token"),
  button: byId("upload-register"),
  status: byId("upload-status"),
};
/** The fit report's section (index.html). */
const fitParts = {
  section: byId("fit"),
  title: byId("fit-title"),
  note: byId("fit-note"),
  report: byId("fit-report"),
  overall: byId("fit-overall"),
  lipGap: byId("fit-lip-gap"),
  regions: byId("fit-regions"),
  warnings: byId("fit-warnings"),
  front: byId("fit-front"),
  frontLink: byId("fit-front-link"),
  side: byId("fit-side"),
  sideLink: byId("fit-side-link"),
};

const params = new URLSearchParams(location.search);
/** Where every fetch and socket goes: the `nodes` list, else the page's own origin. */
const nodes = Nodes.fromLocation(location);
const page = {
  heads: [],
  algorithms: [],
  head: params.get("head") || "scan",
  stream: params.get("stream") || "main",
  /** The recording replayed instead of the stream, or null; `recordings`: the head's. */
  replay: params.get("replay") || null,
  recordings: [],
  token: params.get("token") || "",
  panels: [],
  /** How every view draws the lips (render.js setLips). */
  lips: {
    mode: LIP_MODES.includes(params.get("lips")) ? params.get("lips") : "tint",
    strength: params.has("lipstrength") ? Number(params.get("lipstrength")) : 1,
  },
};
const camera = new OrbitCamera();
const sound = new Sound({ onChange: showSoundState });
const talk = new Talk({ onState: showTalkState });
// For tests: the microphone's producer.
window.facewireTalk = talk;
/** The codec view 1 asks for (null: none), chosen at start. */
let soundCodec = null;
// For tests and the curious: each drawn frame's distance from its sound (sound.syncLog).
window.facewireSound = sound;
// For tests: each view's live head (head-view.js), its element's `headView`.
window.facewireViews = () => page.panels.map((panel) => panel.view);
// For tests: the shared camera (drag, pinch and keys move it).
window.facewireCamera = camera;
const chart = new LiveChart(byId("chart"));
const replayBar = new ReplayBar((message) => page.panels.forEach((panel) => panel.control(message)));
let statsAt = performance.now();
/** Both views: one camera, one sound, drawn in step; then the chart and, each second, the numbers. */
const group = new HeadGroup({
  camera,
  sound,
  onTick: (now) => {
    chart.draw(now);
    if (now - statsAt >= 1000) {
      statsAt = now;
      for (const panel of page.panels) {
        panel.updateStats(now);
      }
    }
  },
});
// For tests and the curious: the lags and chances the draw target is made from, and the
// pixels drawn while the voice plays (draw-scale.js).
window.facewireDraw = { lags: group.lags, intervals: group.intervals, scale: group.drawScale };
/**
 * The fit report's fetches: `seen` is the chosen head's status when the last one started
 * (a change, e.g. registering to ready, fetches again), `retry` that it failed in a way
 * worth retrying with the next head list read, `generation` drops an answer for a head no
 * longer chosen.
 */
const fit = { head: null, seen: null, retry: false, loading: false, generation: 0 };

async function fetchJson(path) {
  const response = await nodes.fetch(path);
  if (!response.ok) {
    throw new Error(`${path}: HTTP ${response.status}`);
  }
  return response.json();
}

/** The lip controls as `page.lips` has them; the strength only matters for a tint. */
function showLips() {
  const { mode, strength } = page.lips;
  controls.lips.value = mode;
  controls.lipStrength.value = String(strength);
  controls.lipStrength.disabled = mode === "region" || mode === "off";
  controls.lipStrength.setAttribute("aria-valuetext", `${Math.round(strength * 100)} percent`);
  for (const panel of page.panels) {
    panel.setLips(page.lips);
  }
}

function showPageMessage(text) {
  controls.message.hidden = !text;
  controls.message.textContent = text ?? "";
}

/** A letter (`T`) or spec from the URL as the spec the picker holds; empty: the default. */
function resolveAlgorithm(text) {
  const fallback = page.algorithms.find((a) => a.default)?.spec ?? "";
  if (!text) {
    return fallback;
  }
  const found = page.algorithms.find((a) => a.letter.toLowerCase() === text.toLowerCase() || a.spec === text);
  return found ? found.spec : text;
}

/** The spec as the URL shows it: its letter when it is a preset. */
function shortAlgorithm(spec) {
  return page.algorithms.find((a) => a.spec === spec)?.letter ?? spec;
}

function streamsOf(head) {
  return page.heads.find((h) => h.id === head)?.streams ?? [];
}

function fillHeadPicker() {
  const { head } = controls;
  head.replaceChildren();
  for (const info of page.heads) {
    const note = info.status === "ready" ? "" : ` (${info.status})`;
    head.add(new Option(`${info.id}${note}`, info.id));
  }
  if (!page.heads.some((h) => h.id === page.head)) {
    head.add(new Option(`${page.head} (not registered)`, page.head));
  }
  head.value = page.head;
}

/** The picker's value for a recording (the live streams' values are their names). */
const REPLAY_PREFIX = "replay:";

function fillStreamPicker() {
  const { stream } = controls;
  const known = streamsOf(page.head);
  stream.replaceChildren();
  for (const name of known) {
    stream.add(new Option(name, name));
  }
  if (!known.includes(page.stream)) {
    stream.add(new Option(`${page.stream} (no frames yet)`, page.stream));
  }
  const names = page.recordings.map((r) => r.name);
  if (page.replay && !names.includes(page.replay)) {
    names.push(page.replay);
  }
  if (names.length > 0) {
    const group = document.createElement("optgroup");
    group.label = "Recordings (replay)";
    for (const name of names) {
      group.append(new Option(`${name} (replay)`, `${REPLAY_PREFIX}${name}`));
    }
    stream.append(group);
  }
  stream.value = page.replay ? `${REPLAY_PREFIX}${page.replay}` : page.stream;
}

/** The chosen head's recordings (for the stream picker); a failed read keeps the last list. */
async function loadRecordings() {
  const head = page.head;
  try {
    const recordings = await fetchJson(`/v1/heads/${encodeURIComponent(head)}/recordings`);
    if (head === page.head && JSON.stringify(recordings) !== JSON.stringify(page.recordings)) {
      page.recordings = recordings;
      if (document.activeElement !== controls.stream) {
        fillStreamPicker();
      }
    }
  } catch {
    // An older server, or the head is gone: no recordings to offer.
  }
}

function writeUrl() {
  const query = new URLSearchParams({ head: page.head, stream: page.stream });
  if (page.replay) {
    query.set("replay", page.replay);
  }
  page.panels.forEach((panel, i) => {
    const suffix = i === 0 ? "" : "2";
    query.set(`algo${suffix}`, shortAlgorithm(panel.settings.algorithm));
    if (panel.settings.heat) {
      query.set(`heat${suffix}`, panel.settings.heat === "folds" ? "folds" : "1");
    }
    if (panel.settings.heatMax !== DEFAULT_HEAT_MAX) {
      query.set(`heatmax${suffix}`, String(panel.settings.heatMax));
    }
    if (panel.look.mode !== "front") {
      query.set(`view${suffix}`, panel.look.mode);
    }
    if (panel.look.cutDeg !== 0) {
      query.set(`cut${suffix}`, String(panel.look.cutDeg));
    }
  });
  if (camera.closeUp) {
    query.set("mouth", "1");
  }
  if (page.lips.mode !== "tint") {
    query.set("lips", page.lips.mode);
  }
  if (page.lips.strength !== 1) {
    query.set("lipstrength", String(page.lips.strength));
  }
  if (page.token) {
    query.set("token", page.token);
  }
  if (params.has("nodes")) {
    query.set("nodes", params.get("nodes"));
  }
  history.replaceState(null, "", `?${query}`);
}

/**
 * The chosen head's status and fit summary in the head list, as a key: when it changes
 * (the head became ready, failed, was registered again) the fit report is fetched again.
 */
function headKey(id) {
  const info = page.heads.find((h) => h.id === id);
  return JSON.stringify([info?.status ?? null, info?.fit ?? null]);
}

/**
 * Fetches the chosen head's fit report and shows it. Never throws: a failure is a line in
 * the section, and an older server without the endpoint leaves the section hidden.
 */
async function loadFit() {
  const head = page.head;
  const generation = ++fit.generation;
  if (fit.head !== head) {
    fitParts.section.hidden = true; // the last head's report must not show under this one's name
  }
  Object.assign(fit, { head, seen: headKey(head), retry: false, loading: true });
  const outcome = await fetchFit(head);
  if (generation !== fit.generation) {
    return; // another head was picked meanwhile, and its own fetch shows it
  }
  Object.assign(fit, { retry: outcome.kind === "error", loading: false });
  showFit(head, outcome);
}

/** The endpoint's answer as fitOutcome gives it; a network failure is an error. */
async function fetchFit(head) {
  try {
    const response = await nodes.fetch(fitPaths(head).report);
    const body = await response.json().catch(() => null); // a proxy's HTML 404, say
    return fitOutcome(response.status, body);
  } catch (error) {
    return { kind: "error", text: `Cannot read the fit report: ${error.message}.` };
  }
}

/** After a head list read: fetches the report again if the head changed state or the last fetch failed. */
function refreshFit() {
  if (!fit.loading && (fit.retry || headKey(page.head) !== fit.seen)) {
    loadFit();
  }
}

/** Shows `outcome` (fit.js fitOutcome) for `head`: the report, a line, or nothing. */
function showFit(head, outcome) {
  const { section, title, note, report } = fitParts;
  section.hidden = outcome.kind === "none";
  title.textContent = `Fit of head "${head}"`;
  note.hidden = !outcome.text;
  note.textContent = outcome.text ?? "";
  note.dataset.kind = outcome.kind; // an error is styled as one, a note (registering) is not
  report.hidden = outcome.kind !== "report";
  if (outcome.kind === "report") {
    fillFitReport(head, outcome.fit);
  }
}

/** The report's numbers, region table, warnings and pictures (formatFit's text). */
function fillFitReport(head, report) {
  const { overall, lipGap, regions, warnings } = fitParts;
  overall.textContent = report.overall;
  lipGap.textContent = report.lipGap;
  regions.replaceChildren(...report.regions.map(regionRow));
  regions.closest("table").hidden = report.regions.length === 0;
  warnings.replaceChildren(...report.warnings.map(warningItem));
  warnings.hidden = report.warnings.length === 0;
  const paths = fitPaths(head);
  showPicture(fitParts.front, fitParts.frontLink, nodes.httpUrl(paths.front));
  showPicture(fitParts.side, fitParts.sideLink, nodes.httpUrl(paths.side));
}

function regionRow({ name, mean, max }) {
  const row = document.createElement("tr");
  const header = document.createElement("th");
  header.scope = "row";
  header.textContent = name;
  row.append(header);
  for (const value of [mean, max]) {
    const cell = document.createElement("td");
    cell.textContent = value;
    row.append(cell);
  }
  return row;
}

/** A warning's message, marked as one in words as well as colour. */
function warningItem(message) {
  const item = document.createElement("li");
  const mark = document.createElement("strong");
  mark.textContent = "Warning: ";
  item.append(mark, message);
  return item;
}

/** A thumbnail linking to its full picture (start() hides the link if the picture does not load). */
function showPicture(img, link, url) {
  link.hidden = false;
  link.href = url;
  img.src = url;
}

/** What a view connects with: the page's head and stream, the view's own choices. */
function connectSettings({ algorithm, heat, heatMax }) {
  return {
    head: page.head,
    stream: page.stream,
    replay: page.replay,
    algorithm,
    heat,
    heatMax,
    token: page.token,
    knownStreams: streamsOf(page.head),
  };
}

/** The `heat` (or `heat2`) URL parameter: `1` roughness, `folds` folds, else none. */
function heatParam(name) {
  return { 1: "roughness", folds: "folds" }[params.get(name)] ?? null;
}

/** The `heatmax` (or `heatmax2`) URL parameter, when it is a positive number. */
function heatMaxParam(name) {
  const value = Number(params.get(name));
  return params.has(name) && value > 0 && Number.isFinite(value) ? value : DEFAULT_HEAT_MAX;
}

/** The look a view starts with, from `view` and `cut` (or `view2` and `cut2`). */
function lookParam(suffix) {
  return { mode: params.get(`view${suffix}`) ?? "front", cutDeg: Number(params.get(`cut${suffix}`) ?? 0) };
}

/** The Sound button: starts the sound, then mutes and unmutes it. */
async function toggleSound() {
  if (!sound.playing) {
    try {
      await sound.enable();
      sound.setMuted(false);
    } catch (error) {
      showPageMessage(`The sound cannot start: ${error.message}`);
    }
  } else {
    sound.setMuted(!sound.muted);
  }
}

/**
 * The Talk button: the microphone becomes the producer of the chosen head's `talk` stream,
 * its face derived from the voice by the server, and the views watch that stream; pressed
 * again, the stream ends.
 */
function toggleTalk() {
  if (talk.talking) {
    talk.stop();
    return;
  }
  page.stream = TALK_STREAM;
  fillStreamPicker();
  reconnectAll();
  const query = new URLSearchParams({ derive: "visemes" });
  if (page.token) {
    query.set("token", page.token);
  }
  const path = `/v1/heads/${encodeURIComponent(page.head)}/streams/${TALK_STREAM}/produce?${query}`;
  talk.start(nodes.wsUrl(path));
}

function showTalkState(state, message) {
  const on = state === "talking" || state === "starting";
  controls.talk.setAttribute("aria-pressed", String(on));
  controls.talk.textContent = on ? "Stop talking" : "Talk";
  if (state === "error") {
    showPageMessage(`Talk: ${message}.`);
  }
}

function showSoundState() {
  const on = sound.playing && !sound.muted;
  controls.sound.setAttribute("aria-pressed", String(on));
  controls.sound.textContent = on ? "Sound off" : "Sound on";
  controls.sound.disabled = soundCodec === null;
  controls.volume.disabled = !sound.playing;
}

function addPanel(algorithm, heat, heatMax) {
  const index = page.panels.length;
  const panel = new Panel({
    index,
    container: controls.views,
    algorithms: page.algorithms,
    chart,
    group,
    nodes,
    audio: index === 0 ? soundCodec : null,
    lips: page.lips,
    look: lookParam(index === 0 ? "" : "2"),
    onSettings: writeUrl,
    // View 1 speaks for the replay: the bar shows where its replay stands.
    onReplay: index === 0 ? (message) => replayBar.update(message) : undefined,
    onRecording: index === 0 ? (recording) => replayBar.show(recording) : undefined,
    onKey: (event) => {
      if (event.key === "m" && !event.altKey && !event.ctrlKey && !event.metaKey) {
        setCloseUp(!camera.closeUp);
        event.preventDefault();
      }
    },
  });
  page.panels.push(panel);
  panel.connect(connectSettings({ algorithm, heat, heatMax }));
}

function setCompare(on) {
  controls.compare.setAttribute("aria-pressed", String(on));
  controls.views.classList.toggle("two", on);
  if (on && page.panels.length === 1) {
    const first = page.panels[0].settings.algorithm;
    const other = page.algorithms.find((a) => a.spec !== first)?.spec ?? first;
    addPanel(
      // A second look (view2=) at the same algorithm, unless algo2= picks one.
      params.has("algo2") ? resolveAlgorithm(params.get("algo2")) : params.has("view2") ? first : other,
      heatParam("heat2"),
      heatMaxParam("heatmax2"),
    );
  } else if (!on && page.panels.length === 2) {
    page.panels.pop().destroy();
  }
  writeUrl();
}

/** The mouth close-up: the camera, the button and the URL (`mouth=1`). */
function setCloseUp(on) {
  camera.setCloseUp(on);
  controls.mouthView.setAttribute("aria-pressed", String(on));
  writeUrl();
}

function reconnectAll() {
  for (const panel of page.panels) {
    panel.connect(connectSettings(panel.settings));
  }
  writeUrl();
}

async function start() {
  for (const [img, link] of [[fitParts.front, fitParts.frontLink], [fitParts.side, fitParts.sideLink]]) {
    img.addEventListener("error", () => {
      link.hidden = true; // a broken picture says nothing; the numbers still do
    });
  }
  controls.zoomIn.addEventListener("click", () => camera.zoomIn());
  controls.zoomOut.addEventListener("click", () => camera.zoomOut());
  controls.resetView.addEventListener("click", () => camera.reset());
  controls.mouthView.addEventListener("click", () => setCloseUp(!camera.closeUp));
  controls.lips.addEventListener("change", () => {
    page.lips = { ...page.lips, mode: controls.lips.value };
    showLips();
    writeUrl();
  });
  controls.lipStrength.addEventListener("input", () => {
    page.lips = { ...page.lips, strength: Number(controls.lipStrength.value) };
    showLips();
    writeUrl();
  });
  page.lips.strength = Number.isFinite(page.lips.strength) ? Math.max(0, Math.min(1, page.lips.strength)) : 1;
  showLips();
  upload.files.addEventListener("change", () => {
    const head = [...upload.files.files].find((f) => /\.(glb|gltf|obj)$/i.test(f.name));
    if (head && !upload.id.value) {
      upload.id.value = idFromFileName(head.name);
    }
  });
  upload.form.addEventListener("submit", registerUpload);
  controls.sound.addEventListener("click", toggleSound);
  controls.talk.addEventListener("click", toggleTalk);
  controls.volume.addEventListener("input", () => sound.setVolume(Number(controls.volume.value)));
  const asked = params.get("audio");
  soundCodec = asked === "none" ? null : asked === "pcm" || asked === "opus" ? asked : await audioCodec();
  showSoundState();
  camera.setCloseUp(params.get("mouth") === "1");
  controls.mouthView.setAttribute("aria-pressed", String(camera.closeUp));
  controls.compare.addEventListener("click", () =>
    setCompare(controls.compare.getAttribute("aria-pressed") !== "true"),
  );
  controls.head.addEventListener("change", () => {
    page.head = controls.head.value;
    const known = streamsOf(page.head);
    if (!known.includes(page.stream) && known.length > 0) {
      page.stream = known.includes("main") ? "main" : known[0];
    }
    page.recordings = [];
    fillStreamPicker();
    reconnectAll();
    loadFit();
    loadRecordings();
  });
  controls.stream.addEventListener("change", () => {
    const value = controls.stream.value;
    if (value.startsWith(REPLAY_PREFIX)) {
      page.replay = value.slice(REPLAY_PREFIX.length);
    } else {
      page.replay = null;
      page.stream = value;
    }
    reconnectAll();
  });

  const [heads, algorithms] = await Promise.allSettled([fetchJson("/v1/heads"), fetchJson("/v1/algorithms")]);
  const failed = [heads, algorithms].filter((r) => r.status === "rejected").map((r) => r.reason.message);
  if (failed.length > 0) {
    showPageMessage(`Cannot read the server's lists (${failed.join("; ")}); the views connect anyway.`);
  }
  page.heads = heads.value ?? [];
  page.algorithms = algorithms.value ?? [];
  if (!params.has("head") && page.heads.length > 0 && !page.heads.some((h) => h.id === page.head)) {
    page.head = page.heads[0].id;
  }
  fillHeadPicker();
  fillStreamPicker();
  loadFit(); // before the 3D view: the report is worth showing even without WebGL
  loadRecordings();
  try {
    addPanel(resolveAlgorithm(params.get("algo")), heatParam("heat"), heatMaxParam("heatmax"));
  } catch (error) {
    showPageMessage(`The 3D view cannot start: ${error.message}`);
    return;
  }
  setCompare(params.has("algo2") || params.has("view2"));
  setInterval(refreshHeads, LIST_REFRESH_MS);
}

/** A line under "Your own head": `kind` "error" styles it as one. */
function showUploadStatus(text, kind = "note") {
  upload.status.hidden = !text;
  upload.status.textContent = text ?? "";
  upload.status.dataset.kind = kind;
}

/** Registers the picked files as the head named, then shows that head and its fit. */
async function registerUpload(event) {
  event.preventDefault();
  const id = upload.id.value.trim();
  upload.button.disabled = true;
  const outcome = await registerHead({
    nodes,
    files: [...upload.files.files],
    id,
    token: upload.token.value,
    onProgress: (text) => showUploadStatus(`${text}…`),
  });
  upload.button.disabled = false;
  if (!outcome.ok) {
    showUploadStatus(outcome.text, "error");
    return;
  }
  const became = sourceSummary(outcome.source);
  showUploadStatus(`"${id}" is registered and shown above.${became ? ` ${became}` : ""}`);
  await refreshHeads();
  page.head = id;
  page.replay = null;
  page.recordings = [];
  fillHeadPicker();
  fillStreamPicker();
  reconnectAll();
  loadFit();
}

/**
 * Reads the head list again: heads registered and streams started since the page loaded
 * appear in the pickers (the choices stay), and the fit report follows the chosen head's
 * status. A failed read keeps the old list.
 */
async function refreshHeads() {
  let heads;
  try {
    heads = await fetchJson("/v1/heads");
  } catch {
    return;
  }
  const changed = JSON.stringify(heads) !== JSON.stringify(page.heads);
  page.heads = heads;
  refreshFit();
  loadRecordings();
  if (!changed) {
    return;
  }
  if (document.activeElement !== controls.head) {
    fillHeadPicker();
  }
  if (document.activeElement !== controls.stream) {
    fillStreamPicker();
  }
  for (const panel of page.panels) {
    panel.setKnownStreams(streamsOf(page.head));
  }
}

start();
