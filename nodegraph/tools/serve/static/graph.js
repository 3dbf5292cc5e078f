// The DAG as SVG: a column per topological generation (laid out by the server), input ports on the left of a
// node, output ports (click one to view it) on the right; edges from output to input ports. The columns wrap
// into bands as wide as the pane (as many columns as fit, at least one), each band below the one before, so a
// wide pipeline scrolls down, not sideways.
const NS = "http://www.w3.org/2000/svg";
const W = 150, GAPX = 46, GAPY = 26, ROWH = 16, HEAD = 46;

function el(name, attrs, parent) {
  const e = document.createElementNS(NS, name);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  if (parent) parent.appendChild(e);
  return e;
}

export function bandsOf(width, columns) {
  // columns per band: as many as fit `width` pixels (at least one)
  return Math.max(1, Math.min(columns, Math.floor((width - 16 + GAPX) / (W + GAPX))));
}

export function drawGraph(svg, state, opts) {
  svg.replaceChildren();
  const pos = new Map();
  const colY = new Map();
  const boxes = [];
  const nodes = [...state.nodes].sort((a, b) => a.col - b.col || a.row - b.row);
  const columns = nodes.reduce((m, n) => Math.max(m, n.col + 1), 0);
  const pane = svg.parentElement;
  const per = bandsOf(pane ? pane.clientWidth : Infinity, columns);
  const heights = new Map(); // each column's height: a band is as tall as its tallest column
  for (const n of nodes) {
    const h = HEAD + ROWH * Math.max(Object.keys(n.inputs).length, Object.keys(n.outputs).length) + 6;
    heights.set(n.col, (heights.get(n.col) || 0) + h + GAPY);
  }
  const bandTop = [8];
  for (let b = 0; b * per < columns; b++) {
    let tallest = 0;
    for (let c = b * per; c < Math.min(columns, (b + 1) * per); c++) tallest = Math.max(tallest, heights.get(c) || 0);
    bandTop.push(bandTop[b] + tallest + GAPY);
  }
  svg.dataset.bands = String(bandTop.length - 1);
  for (const n of nodes) {
    const ins = Object.keys(n.inputs), outs = Object.keys(n.outputs);
    const h = HEAD + ROWH * Math.max(ins.length, outs.length) + 6;
    const band = Math.floor(n.col / per);
    const x = 8 + (n.col - band * per) * (W + GAPX);
    const y = colY.get(n.col) || bandTop[band];
    colY.set(n.col, y + h + GAPY);
    boxes.push({ n, x, y, h, ins, outs });
    ins.forEach((p, i) => pos.set(`in:${n.id}.${p}`, [x, y + HEAD + ROWH * i + 4, band]));
    outs.forEach((p, i) => pos.set(`out:${n.id}.${p}`, [x + W, y + HEAD + ROWH * i + 4, band]));
  }
  const edges = el("g", {}, svg);
  for (const e of state.edges) {
    const a = pos.get(`out:${e.from}`), b = pos.get(`in:${e.to}`);
    if (!a || !b) continue;
    if (b[2] === a[2]) {  // within a band: an S curve
      const mx = (a[0] + b[0]) / 2;
      el("path", { class: "edge", d: `M${a[0]},${a[1]} C${mx},${a[1]} ${mx},${b[1]} ${b[0]},${b[1]}` }, edges);
    } else {  // into a later band: down the gutter right of its column, along the gap above the band, in at the left
      const gx = a[0] + GAPX / 2, gy = bandTop[b[2]] - GAPY / 2, lx = 3;
      el("path", { class: "edge wrap", d: `M${a[0]},${a[1]} H${gx} V${gy} H${lx} V${b[1]} H${b[0]}` }, edges);
    }
  }
  let maxX = 0, maxY = 0;
  for (const { n, x, y, h, ins, outs } of boxes) {
    const g = el("g", { class: `node${n.id === opts.selected ? " selected" : ""}`, "data-node": n.id,
                        transform: `translate(${x},${y})` }, svg);
    el("rect", { width: W, height: h }, g);
    const title = el("text", { x: 8, y: 15 }, g);
    title.textContent = n.id;
    const type = el("text", { x: 8, y: 28, class: "type" }, g);
    type.textContent = n.type;
    const meta = el("text", { x: 8, y: 40, class: "meta", "data-status": n.status }, g);
    meta.textContent = `${n.status}${n.computes ? ` · ${n.ms.toFixed(1)} ms · ${n.computes}×` : ""}`;
    const dot = el("circle", { cx: W - 10, cy: 11, r: 4, class: `status-${n.status}` }, g);
    dot.style.fill = "#666";
    g.addEventListener("click", (ev) => { if (!ev.target.closest(".port.out")) opts.onNode(n.id); });
    ins.forEach((p, i) => {
      const pg = el("g", { class: "port in", transform: `translate(0,${HEAD + ROWH * i + 4})` }, g);
      el("circle", { r: 4 }, pg);
      const t = el("text", { x: 7, y: 3 }, pg);
      t.textContent = p;
      const tip = el("title", {}, pg);
      tip.textContent = `${p}: ${n.inputs[p].type}${n.inputs[p].from ? " ← " + n.inputs[p].from : ""}`;
    });
    outs.forEach((p, i) => {
      const ref = `${n.id}.${p}`;
      const pg = el("g", { class: `port out${ref === opts.viewed ? " viewed" : ""}`, "data-port": ref,
                           transform: `translate(${W},${HEAD + ROWH * i + 4})` }, g);
      el("circle", { r: 5 }, pg);
      const t = el("text", { x: -7, y: 3, "text-anchor": "end" }, pg);
      t.textContent = p;
      const tip = el("title", {}, pg);
      tip.textContent = `${ref}: ${n.outputs[p].type}. ${n.outputs[p].doc}`;
      pg.addEventListener("click", (ev) => { ev.stopPropagation(); opts.onPort(ref); });
    });
    maxX = Math.max(maxX, x + W + 10);
    maxY = Math.max(maxY, y + h + 10);
  }
  svg.setAttribute("width", maxX);
  svg.setAttribute("height", maxY);
}
