// The buffer viewer: the image the server sent (at the size it is shown), zoom (wheel) about the cursor, pan
// (drag), and the buffer's value under the cursor (asked of the server, which answers from its read-back).
export class Viewer {
  constructor(canvas, box, hooks) {
    this.canvas = canvas;
    this.box_ = box;
    this.hooks = hooks;
    this.ctx = canvas.getContext("2d");
    this.off = document.createElement("canvas");
    this.full = null; // [w, h] of the buffer
    this.zoom = null; // screen (CSS) pixels per buffer pixel; null: fit
    this.pan = [0, 0];
    this.pendingProbe = null;
    new ResizeObserver(() => { this.layout(); this.request(); }).observe(box);
    canvas.addEventListener("wheel", (e) => this.onWheel(e), { passive: false });
    canvas.addEventListener("mousedown", (e) => this.onDrag(e));
    canvas.addEventListener("mousemove", (e) => this.onMove(e));
    this.layout();
  }

  box() {
    // the size the picture is shown at, in device pixels: the server draws it at this size (never larger than
    // the buffer), so a shrunk view costs no more than it shows
    const dpr = window.devicePixelRatio || 1;
    const r = this.box_.getBoundingClientRect();
    if (!this.full || this.zoom === null) return { width: Math.max(1, Math.round(r.width * dpr)), height: Math.max(1, Math.round(r.height * dpr)) };
    return { width: Math.max(1, Math.ceil(this.full[0] * this.zoom * dpr)), height: Math.max(1, Math.ceil(this.full[1] * this.zoom * dpr)) };
  }

  request() {
    clearTimeout(this.timer);
    this.timer = setTimeout(() => this.hooks.request(this.box()), 60);
  }

  layout() {
    const dpr = window.devicePixelRatio || 1;
    const r = this.box_.getBoundingClientRect();
    this.canvas.width = Math.max(1, Math.round(r.width * dpr));
    this.canvas.height = Math.max(1, Math.round(r.height * dpr));
    this.canvas.style.width = `${r.width}px`;
    this.canvas.style.height = `${r.height}px`;
    this.draw();
  }

  fitZoom() {
    const r = this.box_.getBoundingClientRect();
    return this.full ? Math.min(r.width / this.full[0], r.height / this.full[1]) : 1;
  }

  scale() { return this.zoom === null ? this.fitZoom() : this.zoom; }

  offset() {
    if (this.zoom !== null) return this.pan;
    const r = this.box_.getBoundingClientRect();
    const s = this.fitZoom();
    return [(r.width - this.full[0] * s) / 2, (r.height - this.full[1] * s) / 2];
  }

  reset() { this.zoom = null; this.pan = [0, 0]; this.draw(); }

  oneToOne() {
    const r = this.box_.getBoundingClientRect();
    this.zoom = 1 / (window.devicePixelRatio || 1);
    if (this.full) this.pan = [(r.width - this.full[0] * this.zoom) / 2, (r.height - this.full[1] * this.zoom) / 2];
    this.draw();
    this.request();
  }

  show(header, pixels) {
    this.full = header.full;
    this.off.width = header.width;
    this.off.height = header.height;
    this.off.getContext("2d").putImageData(new ImageData(pixels, header.width, header.height), 0, 0);
    this.draw();
  }

  clear() { this.full = null; this.draw(); }

  draw() {
    const ctx = this.ctx;
    const dpr = window.devicePixelRatio || 1;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    if (!this.full) return;
    const s = this.scale();
    const [ox, oy] = this.offset();
    ctx.imageSmoothingEnabled = s * dpr < this.off.width / this.full[0];
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.drawImage(this.off, ox, oy, this.full[0] * s, this.full[1] * s);
  }

  at(e) {
    const r = this.canvas.getBoundingClientRect();
    const s = this.scale();
    const [ox, oy] = this.offset();
    return [Math.floor((e.clientX - r.left - ox) / s), Math.floor((e.clientY - r.top - oy) / s)];
  }

  onWheel(e) {
    if (!this.full) return;
    e.preventDefault();
    const r = this.canvas.getBoundingClientRect();
    const s = this.scale();
    const [ox, oy] = this.offset();
    const mx = e.clientX - r.left, my = e.clientY - r.top;
    const ns = Math.min(64, Math.max(0.02, s * Math.exp(-e.deltaY * 0.0015)));
    this.pan = [mx - ((mx - ox) / s) * ns, my - ((my - oy) / s) * ns];
    this.zoom = ns;
    this.draw();
    this.request();
  }

  onDrag(e) {
    if (!this.full) return;
    if (this.zoom === null) { this.pan = this.offset(); this.zoom = this.scale(); }
    const start = [e.clientX, e.clientY], p0 = [...this.pan];
    const move = (ev) => { this.pan = [p0[0] + ev.clientX - start[0], p0[1] + ev.clientY - start[1]]; this.draw(); };
    const up = () => { window.removeEventListener("mousemove", move); window.removeEventListener("mouseup", up); };
    window.addEventListener("mousemove", move);
    window.addEventListener("mouseup", up);
  }

  onMove(e) {
    if (!this.full) return;
    const [x, y] = this.at(e);
    if (this.pendingProbe === null) requestAnimationFrame(() => { const [px, py] = this.pendingProbe; this.pendingProbe = null; this.hooks.probe(px, py); });
    this.pendingProbe = [x, y];
  }
}
