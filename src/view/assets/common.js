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

const PALETTE = ['#2b6cb0', '#d9480f', '#2f9e44', '#862e9c', '#e8590c', '#0b7285', '#c2255c', '#5c940d'];

/** Positive values only (for log scales): others become null. */
function positive(a) {
  return a.map((v) => (v !== null && v > 0 && Number.isFinite(v) ? v : null));
}

/**
 * A uPlot line plot. series: [{label, values}] sharing xs. opts: {log, marker: () => x or null,
 * onPick: (index) => void, width, height, xLabel}.
 */
function linePlot(target, title, xs, series, opts) {
  const box = el('div', { class: 'plot' }, [el('div', { class: 'title', text: title })]);
  target.append(box);
  const width = opts.width || Math.max(300, box.clientWidth - 6);
  const u = new uPlot({
    width,
    height: opts.height || 150,
    legend: { show: series.length > 1 || !!opts.legend },
    cursor: { drag: { x: false, y: false } },
    scales: { x: { time: false }, y: opts.log ? { distr: 3 } : {} },
    axes: [{ label: opts.xLabel || '', size: 30, labelSize: 14 }, { size: 62, values: (u, vals) => vals.map(fmt) }],
    series: [{ label: opts.xLabel || 'x' }].concat(series.map((s, i) => ({
      label: s.label,
      stroke: s.color || PALETTE[i % PALETTE.length],
      width: 1.5,
      points: { show: xs.length < 60 },
      spanGaps: false,
    }))),
    hooks: {
      draw: [(u) => {
        const x = opts.marker ? opts.marker() : null;
        if (x === null || x === undefined) return;
        const px = u.valToPos(x, 'x', true);
        const ctx = u.ctx;
        ctx.save();
        ctx.strokeStyle = '#e03131';
        ctx.lineWidth = 2;
        ctx.beginPath();
        ctx.moveTo(px, u.bbox.top);
        ctx.lineTo(px, u.bbox.top + u.bbox.height);
        ctx.stroke();
        ctx.restore();
      }],
    },
  }, [xs].concat(series.map((s) => (opts.log ? positive(s.values) : s.values))), box);
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
