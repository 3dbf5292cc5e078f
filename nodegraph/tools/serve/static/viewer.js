// The buffer viewer: the image the server sent (at the size it is shown), zoom (wheel) about the cursor, pan
// (drag), and the buffer's value under the cursor (asked of the server, which answers from its read-back).
export class Viewer {
  constructor(canvas, box, hooks) {
    this.canvas = canvas;
    this.box_ = box;
    this.hooks = hooks;
    this.ctx = canvas.getContext("2d");
    this.bitmap = null; // the picture as sent (decoded by the browser, off the main thread)
    this.owned = false; // whether this.bitmap is outside the kept pictures (closed when replaced)
    this.kept = new Map(); // vid -> decoded picture, the least recently shown first (the server sends a
    // header alone for a view the page says it holds)
    this.shownSeq = 0; // the newest picture asked to be shown: an older decode finishing later is dropped
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

  held() { return [...this.kept.keys()]; }

  // the picture is a PNG (8-bit grey, RGB, RGBA or paletted, no colour profile): the browser decodes it off the
  // main thread, and its values reach the canvas as sent; or, for `header.reuse`, the picture kept under
  // header.vid. Resolves to the picture shown, "missing" for a reuse of a picture no longer kept, or null when a
  // newer picture was shown meanwhile.
  async show(header, png, sum) {
    const seq = ++this.shownSeq;
    let bitmap;
    if (header.reuse) {
      bitmap = this.kept.get(header.vid);
      if (!bitmap) return "missing";
      this.kept.delete(header.vid);
      this.kept.set(header.vid, bitmap); // the most recently shown last
    } else {
      bitmap = await createImageBitmap(new Blob([png], { type: "image/png" }),
                                       { premultiplyAlpha: "none", colorSpaceConversion: "none" });
      bitmap.sum = sum;
      if (seq !== this.shownSeq) { bitmap.close(); return null; }
      if (header.vid) this.keep(header.vid, bitmap);
    }
    if (this.bitmap && this.owned && this.bitmap !== bitmap) this.bitmap.close();
    this.bitmap = bitmap;
    this.owned = !header.vid;
    this.full = header.full;
    this.panels = header.panels || null; // [n, panel width, gap]: panels side by side, each the whole buffer
    this.draw();
    return bitmap;
  }

  keep(vid, bitmap) {
    this.kept.set(vid, bitmap);
    this.keptBytes = (this.keptBytes || 0) + bitmap.width * bitmap.height * 4;
    // 96 MB of pictures (37 of 800x800: every port of a pipeline, looked at in turn, stays)
    while (this.kept.size > 1 && this.keptBytes > 96 * 1024 * 1024) {
      const [old, bm] = this.kept.entries().next().value;
      this.kept.delete(old);
      this.keptBytes -= bm.width * bm.height * 4;
      if (bm === this.bitmap) this.owned = true; // closed when it is replaced
      else bm.close();
    }
  }

  clear() { this.shownSeq += 1; this.full = null; this.draw(); }

  draw() {
    const ctx = this.ctx;
    const dpr = window.devicePixelRatio || 1;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    if (!this.full || !this.bitmap) return;
    const s = this.scale();
    const [ox, oy] = this.offset();
    ctx.imageSmoothingEnabled = s * dpr < this.bitmap.width / this.full[0];
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.drawImage(this.bitmap, ox, oy, this.full[0] * s, this.full[1] * s);
  }

  at(e) {
    const r = this.canvas.getBoundingClientRect();
    const s = this.scale();
    const [ox, oy] = this.offset();
    return [Math.floor((e.clientX - r.left - ox) / s), Math.floor((e.clientY - r.top - oy) / s)];
  }

  // the buffer pixel under a picture point: a point of panel i is the same pixel of the buffer as in panel 0;
  // null in the gap between panels
  pixel([x, y]) {
    if (!this.panels) return [x, y];
    const [n, w, gap] = this.panels;
    const i = Math.floor(x / (w + gap)), px = x - i * (w + gap);
    return i >= 0 && i < n && px < w ? [px, y] : null;
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
    const p = this.pixel(this.at(e));
    if (p === null) return;
    if (this.pendingProbe === null) requestAnimationFrame(() => { const [px, py] = this.pendingProbe; this.pendingProbe = null; this.hooks.probe(px, py); });
    this.pendingProbe = p;
  }
}
