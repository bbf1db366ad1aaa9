// Small SVG plots for the UI: a line with error bars, several lines, a scatter and grouped bars. Written for this page (nothing fetched:
// plant networks are offline), axes with "nice" ticks, every mark a real SVG element the browser test can count.
"use strict";

const Plot = (() => {
  const NS = "http://www.w3.org/2000/svg";
  const W = 560, H = 300, M = { left: 70, right: 16, top: 28, bottom: 44 };

  function el(name, attrs, parent) {
    const node = document.createElementNS(NS, name);
    for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, String(v));
    if (parent) parent.appendChild(node);
    return node;
  }

  function niceTicks(lo, hi, count) {
    if (!(hi > lo)) { const pad = Math.abs(lo) * 0.01 || 1; lo -= pad; hi += pad; }
    const raw = (hi - lo) / count, mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 5, 10].map((f) => f * mag).find((s) => s >= raw);
    const ticks = [];
    for (let t = Math.ceil(lo / step) * step; t <= hi + step * 1e-9; t += step) ticks.push(+t.toPrecision(12));
    return { lo: Math.min(lo, ticks[0]), hi: Math.max(hi, ticks[ticks.length - 1]), ticks };
  }

  function frame(container, opts, xs, ys) {
    const svg = el("svg", { viewBox: `0 0 ${W} ${H}`, width: W, height: H, class: "plot", role: "img" });
    if (opts.id) svg.id = opts.id;
    el("title", {}, svg).textContent = opts.title || "";
    const x = niceTicks(Math.min(...xs), Math.max(...xs), 6), y = niceTicks(Math.min(...ys), Math.max(...ys), 5);
    const sx = (v) => M.left + ((v - x.lo) / (x.hi - x.lo)) * (W - M.left - M.right);
    const sy = (v) => H - M.bottom - ((v - y.lo) / (y.hi - y.lo)) * (H - M.top - M.bottom);
    for (const t of y.ticks) {
      el("line", { x1: M.left, x2: W - M.right, y1: sy(t), y2: sy(t), class: "grid" }, svg);
      el("text", { x: M.left - 6, y: sy(t) + 4, "text-anchor": "end" }, svg).textContent = fmt(t);
    }
    for (const t of x.ticks) {
      el("text", { x: sx(t), y: H - M.bottom + 16, "text-anchor": "middle" }, svg).textContent = fmt(t);
    }
    el("line", { x1: M.left, x2: W - M.right, y1: H - M.bottom, y2: H - M.bottom, class: "axis" }, svg);
    el("line", { x1: M.left, x2: M.left, y1: M.top, y2: H - M.bottom, class: "axis" }, svg);
    el("text", { x: (W + M.left) / 2, y: H - 8, "text-anchor": "middle" }, svg).textContent = opts.xlabel || "";
    el("text", { x: 14, y: H / 2, transform: `rotate(-90 14 ${H / 2})`, "text-anchor": "middle" }, svg)
      .textContent = opts.ylabel || "";
    el("text", { x: M.left, y: 16 }, svg).textContent = opts.title || "";
    container.appendChild(svg);
    return { svg, sx, sy };
  }

  function fmt(v) { return Math.abs(v) >= 1e4 || (Math.abs(v) < 1e-3 && v !== 0) ? v.toExponential(2) : +v.toPrecision(6) + ""; }

  // y(x) as a polyline with ± err bars: a parameter's value over its versions.
  function line(container, opts) {
    const err = opts.err || opts.y.map(() => 0);
    const lows = opts.y.map((v, i) => v - (err[i] || 0)), highs = opts.y.map((v, i) => v + (err[i] || 0));
    const { svg, sx, sy } = frame(container, opts, opts.x, [...lows, ...highs]);
    el("polyline", { points: opts.x.map((v, i) => `${sx(v)},${sy(opts.y[i])}`).join(" "), class: "series" }, svg);
    opts.x.forEach((v, i) => {
      if (err[i]) el("line", { x1: sx(v), x2: sx(v), y1: sy(lows[i]), y2: sy(highs[i]), class: "band" }, svg);
      const dot = el("circle", { cx: sx(v), cy: sy(opts.y[i]), r: 3.5, class: "point" }, svg);
      el("title", {}, dot).textContent = `${opts.x[i]}: ${opts.y[i]}`;
    });
    return svg;
  }

  // Points in a plane: a design's TCP positions seen from above or from the side.
  function scatter(container, opts) {
    const { svg, sx, sy } = frame(container, opts, opts.x, opts.y);
    opts.x.forEach((v, i) => el("circle", { cx: sx(v), cy: sy(opts.y[i]), r: 3, class: "point" }, svg));
    return svg;
  }

  // Grouped bars from zero, one group per index and one bar per series (class s0, s1, …), with a legend: a
  // calibration's per-pose residuals before and after, side by side.
  function bars(container, opts) {
    const n = Math.max(...opts.series.map((s) => s.values.length));
    const all = opts.series.flatMap((s) => s.values);
    const { svg, sx, sy } = frame(container, opts, [0.5, n + 0.5], [0, ...all]);
    const group = (sx(1) - sx(0)) * 0.8, width = group / opts.series.length;
    opts.series.forEach((series, k) => {
      series.values.forEach((v, i) => {
        const left = sx(i + 1) - group / 2 + k * width;
        const bar = el("rect", { x: left, y: sy(v), width: Math.max(width, 0.5), height: sy(0) - sy(v), class: `bar s${k}` }, svg);
        el("title", {}, bar).textContent = `${series.name}, ${i + 1}: ${fmt(v)}`;
      });
      const key = el("g", { class: "legend" }, svg);
      el("rect", { x: W - M.right - 150, y: M.top + k * 16, width: 10, height: 10, class: `bar s${k}` }, key);
      el("text", { x: W - M.right - 135, y: M.top + k * 16 + 9 }, key).textContent = series.name;
    });
    return svg;
  }

  // Several series over one x, each a polyline with its points (class s0, s1, …) and a legend; a null value is a
  // gap: a robot's accuracy over time, measured and predicted, event by event.
  function series(container, opts) {
    const all = opts.series.flatMap((s) => s.values.filter((v) => v != null));
    const { svg, sx, sy } = frame(container, opts, opts.x, all.length ? [0, ...all] : [0, 1]);
    opts.series.forEach((one, k) => {
      const kept = opts.x.map((v, i) => [v, one.values[i], i]).filter(([, y]) => y != null);
      el("polyline", { points: kept.map(([v, y]) => `${sx(v)},${sy(y)}`).join(" "), class: `series s${k}` }, svg);
      for (const [v, y, i] of kept) {
        const dot = el("circle", { cx: sx(v), cy: sy(y), r: 3.5, class: `point s${k}` }, svg);
        el("title", {}, dot).textContent = `${one.name}, ${(opts.labels || [])[i] ?? v}: ${fmt(y)}`;
      }
      const key = el("g", { class: "legend" }, svg);
      el("rect", { x: W - M.right - 190, y: M.top + k * 16, width: 10, height: 10, class: `bar s${k}` }, key);
      el("text", { x: W - M.right - 175, y: M.top + k * 16 + 9 }, key).textContent = one.name;
    });
    return svg;
  }

  return { line, scatter, bars, series };
})();
