// Helpers shared by the replay and solve pages.
'use strict';
const DATA = JSON.parse(document.getElementById('lcpbench-data').textContent);
const APP = document.getElementById('app');
const STATE_EL = document.getElementById('lcpbench-state');
window.lcpbenchState = { ready: false };

/** Publish test-visible state on window.lcpbenchState and #lcpbench-state data attributes. */
function publishState(fields) {
  Object.assign(window.lcpbenchState, fields);
  for (const [k, v] of Object.entries(fields)) {
    const name = 'data-' + k.replace(/[A-Z]/g, (c) => '-' + c.toLowerCase());
    STATE_EL.setAttribute(name, typeof v === 'boolean' ? (v ? '1' : '0') : String(v));
  }
}

/** Create an element: el('div', {class: 'x'}, [children or text]). */
// A user-given name (scene, body, recording label) isolated from the text around it with
// U+2068 FIRST STRONG ISOLATE … U+2069 POP DIRECTIONAL ISOLATE, as <bdi> does: a right-to-left
// override inside the name cannot reorder the rest of the line.
function iso(name) {
  return '\u2068' + String(name) + '\u2069';
}

// "1st", "2nd", "3rd", "4th", "11th", "12th", "13th", "21st", …
function ordinal(k) {
  const tens = k % 100;
  const suffix = tens >= 11 && tens <= 13 ? 'th' : ({ 1: 'st', 2: 'nd', 3: 'rd' }[k % 10] || 'th');
  return `${k}${suffix}`;
}

function el(tag, attrs, children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === 'class') e.className = v;
    else if (k === 'text') e.textContent = v;
    else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v);
  }
  for (const c of [].concat(children || [])) {
    e.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return e;
}

/** A number for a table: 4 significant digits, exponent when small or large. */
function fmt(x) {
  if (x === null || x === undefined || Number.isNaN(x)) return '–';
  if (!Number.isFinite(x)) return x > 0 ? '∞' : '−∞';
  if (x === 0) return '0';
  const a = Math.abs(x);
  return a >= 1e-3 && a < 1e5 ? Number(x.toPrecision(4)).toString() : x.toExponential(2);
}

/** The tolerance line's colour, used by no curve (the browser test looks for it). */
const TOLERANCE_COLOUR = '#f0147a';
const PALETTE = ['#2b6cb0', '#d9480f', '#2f9e44', '#862e9c', '#e8590c', '#0b7285', '#c2255c', '#5c940d'];

/** Positive values only (for log scales): others become null. */
function positive(a) {
  return a.map((v) => (v !== null && v > 0 && Number.isFinite(v) ? v : null));
}

/** Axis tick labels: `p` significant digits, exponents as `1e-10` (no padded mantissa). */
function tickLabel(v, p) {
  if (v === null || v === undefined || !Number.isFinite(v)) return '';
  if (v === 0) return '0';
  const a = Math.abs(v);
  if (a >= 1e-3 && a < 1e5) return String(Number(v.toPrecision(p)));
  const [m, e] = v.toExponential(p - 1).split('e');
  return `${String(Number(m))}e${Number(e)}`;
}

/**
 * Labels for a set of ticks that are all different: the fewest significant digits (3 to 15)
 * that tell every tick apart (an energy axis from 4905.0 to 4905.1 needs 6).
 */
function distinctTicks(vals) {
  let labels = [];
  for (let p = 3; p <= 15; p++) {
    labels = vals.map((v) => tickLabel(v, p));
    if (new Set(labels).size === labels.length) return labels;
  }
  return labels;
}

const AXIS_FONT = '11px system-ui, -apple-system, "Segoe UI", sans-serif';
const AXIS_GAP = 4, AXIS_TICK = 6;
let measureCtx = null;
/** Width in CSS pixels of `text` in the axis font. */
function textWidth(text) {
  measureCtx = measureCtx || document.createElement('canvas').getContext('2d');
  measureCtx.font = AXIS_FONT;
  return measureCtx.measureText(text).width;
}

/** Plot geometry checks of every plot on the page, published for the browser tests. */
const PLOT_CHECKS = { plots: 0, empty: 0, clippedLabels: 0, repeatedTicks: 0, toleranceLines: 0 };

/**
 * Check the labels uPlot drew: y labels (right-aligned left of the plot area) must start at or
 * right of the canvas's left edge, x labels (centred under their tick) must lie within the
 * canvas, and no two labels of an axis may repeat.
 */
function checkAxes(u, labels) {
  const ratio = uPlot.pxRatio || window.devicePixelRatio || 1;
  const left = u.bbox.left / ratio;
  let clipped = 0, repeated = 0;
  const y = labels.y.filter((t) => t !== '');
  for (const t of y) if (left - AXIS_TICK - AXIS_GAP - textWidth(t) < 0) clipped++;
  repeated += y.length - new Set(y).size;
  labels.x.forEach((t, k) => {
    if (t === '') return;
    const x = u.valToPos(labels.xVals[k], 'x');
    const w = textWidth(t);
    if (x + left - w / 2 < 0 || x + left + w / 2 > u.width) clipped++;
  });
  const x = labels.x.filter((t) => t !== '');
  repeated += x.length - new Set(x).size;
  return { clipped, repeated };
}

/**
 * A uPlot line plot. series: [{label, values}] sharing xs. opts: {log, marker: () => x or null,
 * onPick: (index) => void, width, height, xLabel, tolerance}. A plot with no value to draw (no
 * finite value, or none positive on a log scale) says "no data" instead of drawing an empty
 * 0–100 frame, and returns null. With `tolerance`, the y scale reaches it and a dashed line
 * marks it.
 */
function linePlot(target, title, xs, series, opts) {
  const box = el('div', { class: 'plot' }, [el('div', { class: 'title', text: title })]);
  target.append(box);
  PLOT_CHECKS.plots++;
  const data = series.map((s) => (opts.log ? positive(s.values) : s.values.map((v) => (v !== null && Number.isFinite(v) ? v : null))));
  if (xs.length === 0 || data.every((d) => d.every((v) => v === null))) {
    PLOT_CHECKS.empty++;
    box.append(el('p', { class: 'muted nodata', text: 'no data' + (opts.log ? ' (no positive value to show on a log scale)' : '') }));
    publishState(PLOT_CHECKS);
    return null;
  }
  const tol = opts.tolerance > 0 ? opts.tolerance : null;
  const labels = { x: [], xVals: [], y: [] };
  const width = opts.width || Math.max(300, box.clientWidth - 6);
  const yScale = opts.log ? { distr: 3 } : {};
  if (tol !== null && opts.log) {
    yScale.range = (u, min, max) => uPlot.rangeLog(Math.min(min ?? tol, tol), Math.max(max ?? tol, tol), 10, true);
  }
  const ySize = (u, values) => {
    const widest = Math.max(0, ...(values || []).map((t) => textWidth(String(t))));
    return Math.ceil(widest) + AXIS_TICK + AXIS_GAP + 6;
  };
  let drawnTolerance = false;
  const u = new uPlot({
    width,
    height: opts.height || 150,
    legend: { show: series.length > 1 || !!opts.legend },
    cursor: { drag: { x: false, y: false } },
    scales: { x: { time: false }, y: yScale },
    axes: [
      { label: opts.xLabel || '', size: 34, labelSize: 14, font: AXIS_FONT, gap: AXIS_GAP, ticks: { size: AXIS_TICK },
        values: (u, vals) => { labels.x = distinctTicks(vals); labels.xVals = vals; return labels.x; } },
      { size: ySize, font: AXIS_FONT, gap: AXIS_GAP, ticks: { size: AXIS_TICK },
        values: (u, vals) => { labels.y = distinctTicks(vals); return labels.y; } },
    ],
    series: [{ label: opts.xLabel || 'x' }].concat(series.map((s, i) => ({
      label: s.label,
      stroke: s.color || PALETTE[i % PALETTE.length],
      width: 1.5,
      points: { show: xs.length < 60 },
      spanGaps: false,
    }))),
    hooks: {
      draw: [(u) => {
        const ctx = u.ctx;
        if (tol !== null) {
          const py = u.valToPos(tol, 'y', true);
          if (py >= u.bbox.top - 0.5 && py <= u.bbox.top + u.bbox.height + 0.5) {
            ctx.save();
            ctx.strokeStyle = TOLERANCE_COLOUR;
            ctx.setLineDash([6, 4]);
            ctx.lineWidth = 1.5;
            ctx.beginPath();
            ctx.moveTo(u.bbox.left, py);
            ctx.lineTo(u.bbox.left + u.bbox.width, py);
            ctx.stroke();
            ctx.setLineDash([]);
            ctx.fillStyle = TOLERANCE_COLOUR;
            ctx.font = AXIS_FONT.replace('11px', `${Math.round(11 * (uPlot.pxRatio || 1))}px`);
            ctx.textAlign = 'right';
            ctx.textBaseline = 'bottom';
            ctx.fillText(`tolerance ${tickLabel(tol, 3)}`, u.bbox.left + u.bbox.width - 4, py - 2);
            ctx.restore();
            if (!drawnTolerance) { drawnTolerance = true; PLOT_CHECKS.toleranceLines++; }
          }
        }
        const x = opts.marker ? opts.marker() : null;
        if (x !== null && x !== undefined) {
          const px = u.valToPos(x, 'x', true);
          ctx.save();
          ctx.strokeStyle = '#e03131';
          ctx.lineWidth = 2;
          ctx.beginPath();
          ctx.moveTo(px, u.bbox.top);
          ctx.lineTo(px, u.bbox.top + u.bbox.height);
          ctx.stroke();
          ctx.restore();
        }
        const c = checkAxes(u, labels);
        u.lcpbenchChecks = c;
        PLOT_CHECKS.clippedLabels = PLOT_CHECKS.clippedLabels - (u.lcpbenchCounted ? u.lcpbenchCounted.clipped : 0) + c.clipped;
        PLOT_CHECKS.repeatedTicks = PLOT_CHECKS.repeatedTicks - (u.lcpbenchCounted ? u.lcpbenchCounted.repeated : 0) + c.repeated;
        u.lcpbenchCounted = c;
        publishState(PLOT_CHECKS);
      }],
    },
  }, [xs].concat(data), box);
  if (opts.onPick) {
    u.over.addEventListener('click', () => {
      if (u.cursor.idx !== null && u.cursor.idx !== undefined) opts.onPick(u.cursor.idx);
    });
  }
  return u;
}

/** Several (x, y) curves with different x on one plot (uPlot.join aligns them). */
function joinedPlot(target, title, curves, opts) {
  const usable = curves.filter((c) => c.xs.length > 0);
  if (usable.length === 0) return null;
  const joined = uPlot.join(usable.map((c) => [c.xs, c.ys]));
  const series = usable.map((c, i) => ({ label: c.label, values: joined[i + 1], color: c.color }));
  return linePlot(target, title, joined[0], series, opts);
}
