// A node's parameters as controls made from their JSON schema: sliders for bounded numbers, colour pickers for
// RGB(A) colours, dropdowns for enumerations, matrix fields for nested fixed-size lists, checkboxes for
// booleans, and a JSON field for anything else. Each change is sent at once (the server coalesces a drag).

function h(tag, attrs, ...kids) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === "class") e.className = v; else if (k.startsWith("on")) e.addEventListener(k.slice(2), v); else e.setAttribute(k, v);
  }
  for (const k of kids) if (k !== null && k !== undefined) e.append(k);
  return e;
}

function plain(schema) {
  // `X | None` → X (None stays sendable through the JSON field)
  if (schema.anyOf) {
    const some = schema.anyOf.filter((s) => s.type !== "null");
    if (some.length === 1) return { ...schema, ...some[0], nullable: true };
  }
  return schema;
}

function choices(schema) {
  if (schema.enum) return schema.enum;
  if (schema.const !== undefined) return [schema.const];
  if (schema.anyOf && schema.anyOf.every((s) => s.enum || s.const !== undefined || s.type === "null")) {
    return schema.anyOf.flatMap((s) => (s.type === "null" ? [null] : s.enum || [s.const]));
  }
  return null;
}

function bounds(s) {
  const lo = s.minimum ?? s.exclusiveMinimum, hi = s.maximum ?? s.exclusiveMaximum;
  return lo !== undefined && hi !== undefined ? [lo, hi] : null;
}

function isNumber(s) { return s && (s.type === "number" || s.type === "integer"); }

function items(s) {
  // a fixed-size list: its element schemas
  if (s.type !== "array") return null;
  if (s.prefixItems) return s.prefixItems.map(plain);
  if (s.items && s.minItems !== undefined && s.minItems === s.maxItems) return Array(s.minItems).fill(plain(s.items));
  return null;
}

function hex(rgb) {
  return "#" + rgb.slice(0, 3).map((c) => Math.round(Math.min(1, Math.max(0, c)) * 255).toString(16).padStart(2, "0")).join("");
}

function numberInput(value, s, onChange) {
  const step = s.type === "integer" ? 1 : "any";
  return h("input", { type: "number", step, value: String(value), onchange: (e) => {
    const v = Number(e.target.value);
    if (e.target.value !== "" && Number.isFinite(v)) onChange(s.type === "integer" ? Math.round(v) : v);
  } });
}

function control(name, schema, value, send) {
  const s = plain(schema);
  const opts = choices(s);
  if (opts) {
    const sel = h("select", { "data-param": name, onchange: (e) => send(JSON.parse(e.target.value)) },
      ...opts.map((o) => { const op = h("option", { value: JSON.stringify(o) }, String(o)); if (JSON.stringify(o) === JSON.stringify(value)) op.selected = true; return op; }));
    return sel;
  }
  if (s.type === "boolean") {
    const cb = h("input", { type: "checkbox", "data-param": name, onchange: (e) => send(e.target.checked) });
    cb.checked = !!value;
    return cb;
  }
  if (isNumber(s) && typeof value === "number") {
    const b = bounds(s);
    if (b) {
      const step = s.type === "integer" ? 1 : (b[1] - b[0]) / 1000;
      const box = numberInput(value, s, (v) => { slider.value = v; send(v); });
      const slider = h("input", { type: "range", "data-param": name, min: b[0], max: b[1], step, value,
        oninput: (e) => { const v = s.type === "integer" ? Math.round(Number(e.target.value)) : Number(e.target.value); box.value = v; send(v); } });
      return h("div", {}, slider, box);
    }
    const box = numberInput(value, s, send);
    box.setAttribute("data-param", name);
    return box;
  }
  const parts = items(s);
  if (parts && Array.isArray(value)) {
    if (/colou?r/i.test(name) && (parts.length === 3 || parts.length === 4) && parts.every(isNumber)) {
      const picker = h("input", { type: "color", "data-param": name, value: hex(value), oninput: (e) => {
        const c = e.target.value;
        const rgb = [1, 3, 5].map((i) => parseInt(c.slice(i, i + 2), 16) / 255);
        send(parts.length === 4 ? [...rgb, value[3]] : rgb);
      } });
      return picker;
    }
    const rows = parts.map(items);
    if (rows.every((r) => r && r.every(isNumber)) && value.every(Array.isArray)) {
      const cur = value.map((r) => [...r]);
      const grid = h("div", { class: "matrix", "data-param": name, style: `grid-template-columns: repeat(${rows[0].length}, 6em)` });
      rows.forEach((r, i) => r.forEach((cs, j) => grid.append(numberInput(cur[i][j], cs, (v) => { cur[i][j] = v; send(cur.map((x) => [...x])); }))));
      return grid;
    }
    if (parts.every(isNumber)) {
      const cur = [...value];
      return h("div", { class: "matrix", "data-param": name, style: `grid-template-columns: repeat(${parts.length}, 6em)` },
        ...parts.map((cs, i) => numberInput(cur[i], cs, (v) => { cur[i] = v; send([...cur]); })));
    }
  }
  const area = h("textarea", { rows: 2, "data-param": name, onchange: (e) => {
    try { send(JSON.parse(e.target.value)); e.target.style.outline = ""; } catch { e.target.style.outline = "1px solid #c55"; }
  } });
  area.value = JSON.stringify(value);
  return area;
}

export function buildControls(root, node, edits, hooks) {
  const focused = document.activeElement && root.contains(document.activeElement) ? document.activeElement : null;
  if (focused && focused.type === "range" && root.dataset.shows === (node && node.id)) return; // mid-drag: keep it
  root.replaceChildren();
  root.dataset.shows = node ? node.id : "";
  if (!node) return;
  const props = (node.schema && node.schema.properties) || {};
  for (const [name, schema] of Object.entries(props)) {
    const value = node.params[name];
    const edited = Object.prototype.hasOwnProperty.call(edits, name);
    const send = (v) => hooks.set(node.id, name, v);
    const reset = edited ? h("button", { class: "reset", title: "back to the file's value", onclick: () => hooks.reset(node.id, name) }, "reset") : null;
    root.append(h("div", { class: `param${edited ? " edited" : ""}` },
      h("label", { class: "name" }, name, reset),
      control(name, schema, value, send),
      h("div", { class: "desc" }, schema.description || "")));
  }
  if (!Object.keys(props).length) root.append(h("p", {}, "no parameters"));
}
