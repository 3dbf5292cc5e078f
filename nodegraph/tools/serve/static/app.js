// The page: one websocket to the server; the graph, the viewer and the parameter controls.
import { drawGraph } from "./graph.js";
import { Viewer } from "./viewer.js";
import { buildControls } from "./controls.js";

const token = new URLSearchParams(location.search).get("token") || "";
const $ = (id) => document.getElementById(id);

// what tests and the benchmark read: the last state, image arrivals, change-to-display latencies
const sg = (window.sg = { state: null, images: 0, lastImage: null, timings: [], sent: new Map(), seq: 0,
                          open: false, probe: null });

let ws = null;
let selectedNode = null;
let viewedPort = null;

function send(msg) {
  if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(msg));
}

// a view request: the port, the size it is shown at, how it is drawn, and the drawn views the page holds
function viewMsg(box, have = true) {
  return { op: "view", port: viewedPort, ...box, ...displaySettings(), have: have ? viewer.held() : [] };
}

const viewer = new Viewer($("view"), $("canvas-box"), {
  request: (box) => send(viewMsg(box)),
  probe: (x, y) => send({ op: "probe", x, y }),
});

function displaySettings() {
  const lo = $("lo").value, hi = $("hi").value;
  return { mode: $("mode").value, exposure: Number($("exposure").value),
           lo: lo === "" ? null : Number(lo), hi: hi === "" ? null : Number(hi) };
}

function viewPort(port) {
  viewedPort = port;
  viewer.zoom = null; // the new port is shown fitted: its request goes out first, the page's own work after
  send(viewMsg(viewer.box()));
  $("port").textContent = port || "";
  $("probe").textContent = "";
  sg.probe = null;
  viewer.reset();
  for (const el of document.querySelectorAll("#graph .port.out")) el.classList.toggle("viewed", el.dataset.port === port);
}

function setParam(node, param, value) {
  const seq = ++sg.seq;
  sg.sent.set(seq, performance.now());
  send({ op: "set", node, param, value, seq });
}

function resetParam(node, param) {
  send({ op: "reset", node, param });
}

function graph(state) {
  graph.width = $("graph-pane").clientWidth;
  drawGraph($("graph"), state, { selected: selectedNode, viewed: viewedPort,
    onPort: (port) => viewPort(port),
    onNode: (id) => { selectedNode = id; render(sg.state); } });
}

// the graph's columns wrap to the pane's width: drawn again when the pane changes width
new ResizeObserver(() => {
  if (sg.state && $("graph-pane").clientWidth !== graph.width) graph(sg.state);
}).observe($("graph-pane"));

function render(state) {
  $("file").textContent = state.file;
  const err = $("error");
  err.hidden = !state.error;
  err.textContent = state.error || "";
  const notice = $("notice");
  if (state.notice) {
    notice.hidden = false;
    notice.textContent = state.notice;
    clearTimeout(render.noticeTimer);
    render.noticeTimer = setTimeout(() => { notice.hidden = true; }, 6000);
  }
  if (!viewedPort && state.outputs) {
    const first = Object.values(state.outputs)[0];
    if (first) { viewedPort = first; $("port").textContent = first; }
  }
  graph(state);
  const node = state.nodes.find((n) => n.id === selectedNode);
  $("params-title").textContent = node ? `${node.id} (${node.type})` : "parameters (click a node)";
  buildControls($("params"), node, state.edits[node ? node.id : ""] || {}, { set: setParam, reset: resetParam });
  const fr = state.frames;
  $("frames").hidden = !fr;
  if (fr) {
    const slider = $("frame");
    slider.min = fr.start; slider.max = fr.end;
    if (!playing) slider.value = state.frame;
    $("frame-label").textContent = `${state.frame} (${fr.kind})`;
  }
}

async function onImage(buf) {
  const recv = performance.now();
  const view = new DataView(buf);
  const n = view.getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
  if (header.port !== viewedPort && viewedPort !== null) return; // an answer to an older request
  const png = new Uint8Array(buf, 4 + n);
  let bitmap;
  try {
    bitmap = await viewer.show(header, png, header.reuse ? 0 : checksum(png));
  } catch (err) {
    $("note").textContent = `the picture of ${header.port} could not be decoded: ${err}`;
    return;
  }
  if (bitmap === "missing") { send(viewMsg(viewer.box(), false)); return; } // dropped meanwhile: ask for it whole
  if (!bitmap) return; // a newer picture came while this one was decoded
  const shown = performance.now();
  $("note").textContent = $("note").title = `${header.full[0]}×${header.full[1]} shown at ${header.width}×${header.height} · ${header.note}`;
  if (header.stats) showStats(header.stats);
  requestAnimationFrame(() => {
    const now = performance.now();
    const t0 = sg.sent.get(header.seq);
    if (t0 !== undefined) {
      sg.timings.push({ seq: header.seq, ms: now - t0 });
      for (const k of sg.sent.keys()) if (k <= header.seq) sg.sent.delete(k);
    }
    sg.images += 1;
    sg.lastImage = { port: header.port, seq: header.seq, width: header.width, height: header.height,
                     sum: bitmap.sum, at: now, recv, shown, read_ms: header.read_ms, draw_ms: header.draw_ms,
                     encode_ms: header.encode_ms || 0,
                     wait_ms: header.wait_ms, ran: !!header.ran, cached: !!header.cached,
                     reuse: !!header.reuse };
  });
}

function showStats(stats) {
  $("stats").textContent = stats.map((s) => `${s.channel}: ${fmt(s.min)}..${fmt(s.max)} mean ${fmt(s.mean)}` +
    `${s.nan ? " nan " + s.nan : ""}${s.inf ? " inf " + s.inf : ""}`).join("   ");
}

function checksum(px) {
  let s = 0;
  for (let i = 0; i < px.length; i += 7) s = (s * 31 + px[i]) >>> 0;
  return s;
}

function fmt(x) {
  return typeof x === "number" ? Number(x.toPrecision(4)).toString() : String(x);
}

function connect() {
  ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws?token=${encodeURIComponent(token)}`);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => {
    sg.open = true;
    $("status").textContent = "connected";
    send(viewMsg(viewer.box()));
  };
  ws.onclose = () => { sg.open = false; $("status").textContent = "disconnected"; };
  ws.onmessage = (ev) => {
    if (typeof ev.data !== "string") { onImage(ev.data); return; }
    const msg = JSON.parse(ev.data);
    if (msg.type === "state") {
      sg.state = msg;
      render(msg);
      const nodes = msg.nodes.filter((n) => n.status === "computed").map((n) => n.id);
      $("status").textContent = msg.error ? "error" : `ran in ${msg.run_ms.toFixed(0)} ms · computed: ${nodes.join(", ") || "nothing"}`;
    } else if (msg.type === "image" && msg.empty) {
      if (msg.port !== viewedPort && viewedPort !== null) return;
      viewer.clear();
      $("note").textContent = msg.note || "";
      sg.lastImage = { port: msg.port, seq: msg.seq, width: 0, height: 0, sum: 0, empty: true, at: performance.now() };
    } else if (msg.type === "stats") {
      if (msg.port === viewedPort) showStats(msg.stats);
    } else if (msg.type === "probe") {
      sg.probe = msg;
      $("probe").textContent = msg.values ? `(${msg.x}, ${msg.y}) ${msg.values.map(fmt).join(", ")}` : "";
    }
  };
}

for (const id of ["mode", "exposure", "lo", "hi"]) {
  $(id).addEventListener("input", () => send(viewMsg(viewer.box())));
}
$("fit").addEventListener("click", () => { viewer.reset(); });
$("one").addEventListener("click", () => viewer.oneToOne());
$("save").addEventListener("click", () => send({ op: "save" }));
$("frame").addEventListener("input", (e) => send({ op: "frame", frame: Number(e.target.value) }));

let playing = null;
$("play").addEventListener("click", () => {
  if (playing) { clearInterval(playing); playing = null; $("play").textContent = "play"; return; }
  $("play").textContent = "stop";
  const fps = (sg.state && sg.state.frames && sg.state.frames.fps) || 24;
  playing = setInterval(() => {
    const s = $("frame");
    let f = Number(s.value) + 1;
    if (f > Number(s.max)) f = Number(s.min);
    s.value = f;
    send({ op: "frame", frame: f });
  }, 1000 / fps);
});

window.sgView = viewPort;
window.sgSet = setParam;
connect();
