/* gshade view, part 2 (after decode.js): one EXR (or two, three) in a page: picture, zoom
 * and pan, every channel's value under the cursor, false colours, junctions, flip / side by
 * side / difference.
 * The data is the JSON in the script element (class gshade-view-data) after each view element
 * (gshade.display.html_view); nothing is loaded from anywhere. */
(function () {
  "use strict";
  const { formatValue, formatShort, loadImage, table, patchColour, MAGENTA } = gshadeDecode;

  // ------------------------------------------------------------------ the view

  /** An object's own property (JSON objects from the page's data: never the prototype's). */
  function own(object, key) {
    return object !== null && typeof object === "object" && Object.prototype.hasOwnProperty.call(object, key) ? object[key] : undefined;
  }

  function el(tag, attrs, text) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    if (text !== undefined) e.textContent = text;
    return e;
  }

  async function mount(root, data) {
    const W = data.width, H = data.height;
    const images = [];
    for (const image of data.images) images.push(await loadImage(image, W, H));
    const maps = new Map();
    for (const [name, hex] of Object.entries(data.colormaps)) maps.set(name, table(hex));
    const n = images.length;
    const gap = Math.max(2, Math.round(W / 40));
    const has = (name) => images.some((im) => im.channels.has(name));
    const patchLabel = images[0].meta.cad ? "face" : "patch";
    // unit vectors shown as RGB (x, y, z from [-1, 1] to [0, 255]): the normal and the
    // reflection direction of an environment render
    const VECTORS = [
      { id: "N", label: "N as RGB", names: ["N.X", "N.Y", "N.Z"] },
      { id: "refl", label: "refl as RGB", names: ["refl.X", "refl.Y", "refl.Z"] },
    ];

    // views of the channels: the picture, every channel no other view shows in false
    // colour (data.scales), N (and refl) as RGB, the patch ids; ids unique whatever the
    // channels' names
    const views = [];
    const ids = new Set(["picture", "N", "refl", "patch"]);
    if (images.some((im) => im.picture)) views.push({ id: "picture", label: "picture", names: ["R", "G", "B", "A"] });
    for (const [name, scale] of Object.entries(data.scales)) {
      let id = name;
      while (ids.has(id)) id = "channel:" + id;
      ids.add(id);
      views.push({ id, label: name + " (false colour)", names: [name], scale });
    }
    for (const vector of VECTORS) {
      if (images.some((im) => vector.names.every((c) => im.channels.has(c)))) views.push({ ...vector, vector: true });
    }
    if (has("patch")) views.push({ id: "patch", label: patchLabel + " ids", names: ["patch"] });
    if (!views.length) throw new Error("no channel to show");
    const state = {
      view: views[0].id, mode: "flip", current: 0, scale: 1, ox: 0, oy: 0,
      junctions: true, pointer: null, drag: null,
    };

    // the DOM
    root.textContent = "";
    root.classList.toggle("gv-several", n > 1);
    const top = el("div", { class: "gv-top" });
    top.append(el("h1", {}, data.title));
    const bar = el("div", { class: "gv-toolbar" });
    const select = el("select", { "data-role": "channel", "aria-label": "channel" });
    for (const v of views) select.append(el("option", { value: v.id, title: v.label }, v.label.length > 60 ? v.label.slice(0, 57) + "…" : v.label));
    bar.append(el("label", {}, "show "), select);
    const modes = el("span", { class: "gv-modes" });
    const modeButtons = {};
    if (n > 1) {
      for (const [m, label] of [["flip", "flip (F)"], ["side", "side by side"], ["diff", "difference"]]) {
        const b = el("button", { type: "button", "data-mode": m }, label);
        b.addEventListener("click", () => {
          const was = state.mode;
          state.mode = m;
          if (m === "flip" && was === "flip") state.current = (state.current + 1) % n;
          if ((m === "side") !== (was === "side")) fit(); // the layout's width changed
          update();
        });
        modeButtons[m] = b;
        modes.append(b);
      }
      bar.append(modes);
    }
    const junctionBox = el("input", { type: "checkbox", "data-role": "junctions" });
    junctionBox.checked = true;
    if (images.some((im) => im.seams)) {
      const l = el("label", {});
      l.append(junctionBox, document.createTextNode(" junctions"));
      bar.append(l);
    }
    const fitButton = el("button", { type: "button", "data-role": "fit" }, "fit (0)");
    bar.append(fitButton);
    const zoomText = el("span", { class: "gv-zoom", "data-role": "zoom" });
    bar.append(zoomText);
    top.append(bar);

    const main = el("div", { class: "gv-main" });
    const stage = el("div", { class: "gv-stage", "data-role": "stage" });
    const canvas = el("canvas", { "data-role": "canvas" });
    const shownLabel = el("div", { class: "gv-shown", "data-role": "shown" });
    stage.append(canvas, shownLabel);
    const side = el("aside", { class: "gv-side" });
    const colourbar = el("div", { class: "gv-colourbar", "data-role": "colourbar" });
    const readout = el("table", { class: "gv-readout", "data-role": "readout" });
    const junctionInfo = el("div", { class: "gv-junction", "data-role": "junction" });
    const legend = el("dl", { class: "gv-legend", "data-role": "legend" });
    const notes = el("div", { class: "gv-notes", "data-role": "notes" });
    for (const note of data.notes || []) notes.append(el("p", {}, String(note)));
    side.append(colourbar, readout, junctionInfo, notes, legend);
    main.append(stage, side);
    root.append(top, main);

    // readout rows: every channel of any image, in the data's order
    const names = [];
    for (const im of images) for (const c of im.meta.channels) if (!names.includes(c.name)) names.push(c.name);
    const head = el("tr");
    head.append(el("th", {}, "pixel"));
    const pixelCells = images.map((im, k) => el("td", { "data-image": String(k), "data-role": "pixel" }));
    head.append(...pixelCells);
    if (n > 1) head.append(el("th", {}, ""));
    const labelRow = el("tr");
    labelRow.append(el("th", {}, ""));
    images.forEach((im, k) => labelRow.append(el("th", { class: "gv-label" }, String.fromCharCode(65 + k) + ": " + im.meta.label)));
    if (n > 1) labelRow.append(el("th", {}, String.fromCharCode(65 + data.difference[0]) + " − " + String.fromCharCode(65 + data.difference[1])));
    readout.append(labelRow, head);
    const cells = new Map();
    for (const name of names) {
      const tr = el("tr", { "data-channel": name });
      tr.append(el("th", { title: name }, name === "patch" ? patchLabel : name));
      const row = images.map((im, k) => { const td = el("td", { "data-image": String(k) }); tr.append(td); return td; });
      if (n > 1) { const td = el("td", { "data-role": "diff" }); tr.append(td); row.diff = td; }
      cells.set(name, row);
      readout.append(tr);
    }

    // legend: what the first image shows
    function legendRow(key, value) {
      if (value === undefined || value === null || value === "") return;
      legend.append(el("dt", {}, key), el("dd", {}, typeof value === "string" ? value : JSON.stringify(value)));
    }
    images.forEach((im, k) => {
      const h = im.meta.header, s = im.meta.settings || {}, shape = own(s, "shape") || {}, render = own(s, "render") || {};
      if (n > 1) legend.append(el("dt", { class: "gv-image" }, String.fromCharCode(65 + k) + ": " + im.meta.label));
      legendRow("scene", own(h, "scene_name"));
      legendRow("legend", own(h, "legend"));
      legendRow("function", own(shape, "function"));
      legendRow("display", own(shape, "display"));
      if (own(shape, "display") !== "colormap") legendRow("period", own(shape, "period"));
      legendRow("range", own(shape, "value_range") ?? own(shape, "range"));
      legendRow("colour map", own(shape, "colormap"));
      legendRow("parameters", own(shape, "params"));
      if (own(render, "width")) legendRow("render", own(render, "width") + "×" + own(render, "height") + ", " + own(render, "spp") + " spp, " + own(render, "lighting"));
      for (const line of im.meta.left_out || []) legendRow("left out", line);
      const version = own(h, "gshade_version");
      legendRow("gshade", version ? version + " (" + own(h, "variant") + ")" : undefined);
    });

    // layers: one offscreen canvas per (image, view) and per difference
    const layers = new Map();
    function layer(k, view) {
      const key = state.mode === "diff" ? "diff/" + view.id : k + "/" + view.id;
      if (layers.has(key)) return layers.get(key);
      const c = document.createElement("canvas");
      c.width = W; c.height = H;
      const ctx = c.getContext("2d");
      const img = ctx.createImageData(W, H);
      const px = img.data;
      c.top = state.mode === "diff" ? paintDifference(px, view) : (paint(px, images[k], view), 0);
      ctx.putImageData(img, 0, 0);
      layers.set(key, c);
      return c;
    }
    function paint(px, im, view) {
      const ch = im.channels, patch = ch.get("patch");
      const on = (i) => (patch ? patch[i] >= 0 : true);
      if (view.id === "picture") { if (im.picture) px.set(im.picture); return; }
      if (view.vector) {
        const [x, y, z] = view.names.map((c) => ch.get(c));
        if (!x || !y || !z) return;
        for (let i = 0; i < W * H; i++) {
          if (!on(i)) continue;
          px[4 * i] = Math.round((x[i] + 1) * 127.5); px[4 * i + 1] = Math.round((y[i] + 1) * 127.5);
          px[4 * i + 2] = Math.round((z[i] + 1) * 127.5); px[4 * i + 3] = 255;
        }
        return;
      }
      if (view.id === "patch") {
        if (!patch) return;
        for (let i = 0; i < W * H; i++) {
          if (patch[i] < 0) continue;
          const c = patchColour(Math.round(patch[i]));
          px[4 * i] = c[0]; px[4 * i + 1] = c[1]; px[4 * i + 2] = c[2]; px[4 * i + 3] = 255;
        }
        return;
      }
      const values = ch.get(view.names[0]);
      if (!values) return;
      const lut = maps.get(view.scale.colormap);
      const [lo, hi] = view.scale.range;
      for (let i = 0; i < W * H; i++) {
        if (!on(i)) continue;
        const v = values[i];
        let c;
        if (!isFinite(v)) c = MAGENTA;
        else {
          const t = Math.min(255, Math.max(0, Math.round(((v - lo) / (hi - lo)) * 255)));
          c = [lut[3 * t], lut[3 * t + 1], lut[3 * t + 2]];
        }
        px[4 * i] = c[0]; px[4 * i + 1] = c[1]; px[4 * i + 2] = c[2]; px[4 * i + 3] = 255;
      }
    }
    function difference(view, i) {
      const [a, b] = data.difference.map((k) => images[k].channels);
      let d = 0;
      for (const name of view.names) {
        const x = a.get(name), y = b.get(name);
        if (!x || !y) continue;
        const e = name === "patch" ? (x[i] === y[i] ? 0 : 1) : Math.abs(x[i] - y[i]);
        if (!(e <= d)) d = e; // NaN wins
      }
      return d;
    }
    function paintDifference(px, view) {
      const d = new Float64Array(W * H);
      let top = 0;
      for (let i = 0; i < W * H; i++) {
        d[i] = difference(view, i);
        if (isFinite(d[i]) && d[i] > top) top = d[i];
      }
      const lut = maps.get("inferno");
      for (let i = 0; i < W * H; i++) {
        let c;
        if (!isFinite(d[i])) c = MAGENTA;
        else {
          const t = top > 0 ? Math.round((d[i] / top) * 255) : 0;
          c = [lut[3 * t], lut[3 * t + 1], lut[3 * t + 2]];
        }
        px[4 * i] = c[0]; px[4 * i + 1] = c[1]; px[4 * i + 2] = c[2]; px[4 * i + 3] = 255;
      }
      return top;
    }

    // junction seams as paths per class, in image pixel units
    function seamPaths(im) {
      if (!im.seams || im.paths) return im.paths;
      im.paths = new Map();
      const { x2, y2, j } = im.seams;
      for (let s = 0; s < j.length; s++) {
        const cls = String(im.meta.junctions[j[s]]["class"]);
        if (!im.paths.has(cls)) im.paths.set(cls, new Path2D());
        const p = im.paths.get(cls);
        const x = x2[s] / 2, y = y2[s] / 2;
        if (x2[s] % 2 === 0) { p.moveTo(x, y - 0.5); p.lineTo(x, y + 0.5); }
        else { p.moveTo(x - 0.5, y); p.lineTo(x + 0.5, y); }
      }
      return im.paths;
    }

    // geometry: which images are drawn where (image pixel units, before the zoom)
    function placed() {
      if (state.mode === "side") return images.map((im, k) => ({ k, x0: k * (W + gap) }));
      if (state.mode === "diff") return [{ k: -1, x0: 0 }];
      return [{ k: n > 1 ? state.current : 0, x0: 0 }];
    }
    function fit() {
      const r = stage.getBoundingClientRect();
      const wide = state.mode === "side" ? n * W + (n - 1) * gap : W;
      let s = Math.min((r.width - 16) / wide, (r.height - 16) / H);
      if (s >= 1) s = Math.floor(s);
      state.scale = s;
      state.ox = Math.round((r.width - wide * s) / 2);
      state.oy = Math.round((r.height - H * s) / 2);
    }
    function pixelAt(clientX, clientY) {
      const r = canvas.getBoundingClientRect();
      const ix = (clientX - r.left - state.ox) / state.scale;
      const iy = (clientY - r.top - state.oy) / state.scale;
      const y = Math.floor(iy);
      if (y < 0 || y >= H) return null;
      for (const p of placed()) {
        const x = Math.floor(ix - p.x0);
        if (x >= 0 && x < W) return { image: p.k < 0 ? 0 : p.k, x, y };
      }
      return null;
    }
    function clientOf(k, x, y) {
      const r = canvas.getBoundingClientRect();
      const p = placed().find((q) => q.k === k) || placed()[0];
      return { clientX: r.left + state.ox + (p.x0 + x + 0.5) * state.scale, clientY: r.top + state.oy + (y + 0.5) * state.scale };
    }

    function draw() {
      const dpr = window.devicePixelRatio || 1;
      const r = stage.getBoundingClientRect();
      const cw = Math.max(1, Math.round(r.width * dpr)), chh = Math.max(1, Math.round(r.height * dpr));
      if (canvas.width !== cw || canvas.height !== chh) { canvas.width = cw; canvas.height = chh; }
      canvas.style.width = r.width + "px"; canvas.style.height = r.height + "px";
      const ctx = canvas.getContext("2d");
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.clearRect(0, 0, cw, chh);
      const s = state.scale * dpr;
      ctx.setTransform(s, 0, 0, s, state.ox * dpr, state.oy * dpr);
      ctx.imageSmoothingEnabled = false;
      const view = views.find((v) => v.id === state.view);
      for (const p of placed()) {
        ctx.drawImage(layer(p.k, view), p.x0, 0);
        const im = images[p.k < 0 ? data.difference[0] : p.k];
        if (state.junctions && im.seams) {
          ctx.save(); ctx.translate(p.x0, 0);
          ctx.lineWidth = 2 / state.scale; ctx.lineCap = "square";
          for (const [cls, path] of seamPaths(im)) {
            ctx.strokeStyle = own(im.meta.junction_colours, cls) || "#ff00ff";
            ctx.stroke(path);
          }
          ctx.restore();
        }
      }
      if (state.pointer && state.scale >= 4) {
        const p = state.pointer;
        for (const q of placed()) {
          ctx.lineWidth = 1.5 / state.scale; ctx.strokeStyle = "#fff";
          ctx.strokeRect(q.x0 + p.x, p.y, 1, 1);
        }
      }
      zoomText.textContent = "zoom " + formatShort(state.scale) + "×";
      for (const [m, b] of Object.entries(modeButtons)) b.classList.toggle("on", m === state.mode);
      shownLabel.textContent = state.mode === "diff"
        ? "|A − B| of " + view.label.replace(" (false colour)", "")
        : placed().map((p) => String.fromCharCode(65 + p.k) + ": " + images[p.k].meta.label).join("  |  ");
      drawColourbar(view);
    }

    function drawColourbar(view) {
      colourbar.textContent = "";
      let lut, lo, hi, title;
      if (state.mode === "diff") {
        lut = maps.get("inferno"); lo = 0; hi = layer(-1, view).top;
        title = "|A − B| (" + view.names.join(", ") + ")" + (hi === 0 ? ": identical" : "");
      } else if (view.scale) {
        lut = maps.get(view.scale.colormap); [lo, hi] = view.scale.range;
        title = view.names[0] + ", " + view.scale.colormap + (view.scale.auto ? " (automatic range)" : "");
      } else return;
      colourbar.append(el("div", { class: "gv-bar-title" }, title));
      const c = el("canvas", { width: "256", height: "14", class: "gv-bar" });
      const ctx = c.getContext("2d");
      for (let t = 0; t < 256; t++) { ctx.fillStyle = "rgb(" + lut[3 * t] + "," + lut[3 * t + 1] + "," + lut[3 * t + 2] + ")"; ctx.fillRect(t, 0, 1, 14); }
      const ticks = el("div", { class: "gv-ticks", "data-role": "range" });
      ticks.append(el("span", {}, formatShort(lo)), el("span", {}, formatShort((lo + hi) / 2)), el("span", {}, formatShort(hi)));
      colourbar.append(c, ticks);
    }

    function nearestJunction(im, x, y) {
      if (!im.seams) return null;
      const { x2, y2, j } = im.seams;
      const cx = 2 * x + 1, cy = 2 * y + 1;
      let best = -1, bestD = Infinity;
      for (let s = 0; s < j.length; s++) {
        const dx = x2[s] - cx, dy = y2[s] - cy, d = dx * dx + dy * dy;
        if (d < bestD) { bestD = d; best = s; }
      }
      if (best < 0) return null;
      return { index: j[best], distance: Math.sqrt(bestD) / 2 };
    }

    function showReadout(p) {
      for (const [k, td] of pixelCells.entries()) td.textContent = p ? p.x + ", " + p.y : "";
      for (const name of names) {
        const row = cells.get(name);
        const v = images.map((im) => (p && im.channels.has(name) ? im.channels.get(name)[p.y * W + p.x] : undefined));
        row.forEach((td, k) => { td.textContent = v[k] === undefined ? (p ? "—" : "") : formatValue(v[k], images[k].stored.get(name)); });
        if (row.diff) {
          const [a, b] = data.difference.map((k) => v[k]);
          row.diff.textContent = a === undefined || b === undefined ? "" : name === "patch" ? (a === b ? "same" : "differs") : formatShort0(a - b);
        }
      }
      junctionInfo.textContent = "";
      if (!p) return;
      const k = state.mode === "diff" ? data.difference[0] : p.image;
      const im = images[k];
      if (!im.meta.junctions) return;
      const near = nearestJunction(im, p.x, p.y);
      junctionInfo.append(el("h2", {}, "nearest junction"));
      if (!near) { junctionInfo.append(el("p", {}, "none visible")); return; }
      const jn = im.meta.junctions[near.index];
      const dl = el("dl", { "data-junction": String(near.index) });
      const row = (a, b) => dl.append(el("dt", {}, a), el("dd", {}, b));
      row("class", jn["class"]);
      row(patchLabel === "face" ? "faces" : "patches", jn.patches.join(" – ") + (jn.sides ? " (" + jn.sides.join(" – ") + ")" : ""));
      if (jn.edge !== undefined) row("edge", String(jn.edge));
      const place = ["at_measure", "at_t", "at_x", "at_y", "at_z"];
      for (const [key, value] of Object.entries(jn)) {
        if (!["class", "patches", "sides", "edge", ...place].includes(key)) row(key.replace(/_/g, " "), typeof value === "number" ? formatShort(value) : String(value));
      }
      // where the measure deciding the class is largest (gshade continuity's max_at)
      if (typeof jn.at_x === "number" && typeof jn.at_y === "number" && typeof jn.at_z === "number") {
        const t = typeof jn.at_t === "number" ? ", t = " + formatShort(jn.at_t) : "";
        row("largest " + String(jn.at_measure || "measure").replace(/_/g, " ") + " at", "(" + [jn.at_x, jn.at_y, jn.at_z].map(formatShort).join(", ") + ")" + t);
      }
      row("distance", formatShort(near.distance) + " px");
      junctionInfo.append(dl);
    }
    function formatShort0(d) {
      if (d === 0) return "0";
      return Number.isFinite(d) ? String(Number(d.toPrecision(6))) : String(d);
    }

    function update() {
      draw();
      showReadout(state.pointer);
    }

    // events
    select.addEventListener("change", () => { state.view = select.value; update(); });
    junctionBox.addEventListener("change", () => { state.junctions = junctionBox.checked; update(); });
    fitButton.addEventListener("click", () => { fit(); update(); });
    canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      const r = canvas.getBoundingClientRect();
      const cx = e.clientX - r.left, cy = e.clientY - r.top;
      const s = Math.min(512, Math.max(1 / 64, state.scale * Math.exp(-e.deltaY * 0.002)));
      state.ox = cx - ((cx - state.ox) * s) / state.scale;
      state.oy = cy - ((cy - state.oy) * s) / state.scale;
      state.scale = s;
      state.pointer = pixelAt(e.clientX, e.clientY);
      update();
    }, { passive: false });
    canvas.addEventListener("pointerdown", (e) => { state.drag = { x: e.clientX, y: e.clientY, ox: state.ox, oy: state.oy }; canvas.setPointerCapture(e.pointerId); });
    canvas.addEventListener("pointerup", () => { state.drag = null; });
    canvas.addEventListener("pointermove", (e) => {
      if (state.drag) {
        state.ox = state.drag.ox + e.clientX - state.drag.x;
        state.oy = state.drag.oy + e.clientY - state.drag.y;
      }
      state.pointer = pixelAt(e.clientX, e.clientY);
      update();
    });
    canvas.addEventListener("pointerleave", () => { state.pointer = null; update(); });
    root.tabIndex = 0;
    root.addEventListener("keydown", (e) => {
      if (e.key === "f" && n > 1) { state.mode = "flip"; state.current = (state.current + 1) % n; update(); }
      else if (e.key === "0") { fit(); update(); }
    });
    window.addEventListener("resize", () => { fit(); update(); });

    fit();
    update();
    root.setAttribute("data-state", "ready");
    return {
      pixelAt,
      clientOf,
      state: () => ({ mode: state.mode, view: state.view, current: state.current, scale: state.scale, ox: state.ox, oy: state.oy }),
      views: () => views.map((v) => v.id),
      formatValue,
    };
  }

  async function start() {
    const roots = document.querySelectorAll("[data-gshade-view]");
    window.gshadeViews = [];
    for (const root of roots) {
      const script = root.nextElementSibling;
      try {
        if (typeof DecompressionStream === "undefined") throw new Error("this browser has no DecompressionStream (Chrome 80, Firefox 113, Safari 16.4 or later needed)");
        const view = await mount(root, JSON.parse(script.textContent));
        window.gshadeViews.push(view);
      } catch (err) {
        root.textContent = "gshade view: " + err.message;
        root.setAttribute("data-state", "error");
      }
    }
    window.gshadeView = window.gshadeViews[0];
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
