// The solve page: every solver on one problem, convergence histories, final f and w per row.
'use strict';
const P = DATA;
const SOLVERS = P.solvers;
document.getElementById('note').textContent =
  `${P.n} rows, ${P.friction.length} friction rows · every solver (${SOLVERS.length}: the matrix solvers on the boxed LCP` +
  (SOLVERS.some((s) => s.problem === 'Coulomb cone') ? ', the cone solvers on its Coulomb-cone form' : '') +
  `) with tolerance ${P.tolerance} on the relative natural-map residual of the problem it solved.`;

APP.append(el('h2', { text: 'Solvers' }));
APP.append(el('div', { class: 'panel' }, [el('table', { id: 'summary' }, [
  el('thead', {}, [el('tr', {}, ['solver', 'problem solved', 'status', 'iterations', 'counted in', 'time (ms)', 'relative residual', 'history points', 'reason']
    .map((h, i) => el('th', { class: [0, 1, 2, 4, 8].includes(i) ? 'l' : '', text: h })))]),
  el('tbody', {}, SOLVERS.map((s, k) => el('tr', {}, [
    el('td', { class: 'l' }, [el('b', { style: 'color:' + PALETTE[k % PALETTE.length], text: s.name })]),
    el('td', { class: 'l', text: s.problem }),
    el('td', { class: 'l' + (s.status === 'converged' ? '' : ' bad'), text: s.status }),
    el('td', { text: String(s.iterations) }), el('td', { class: 'l muted', text: s.iteration_unit }), el('td', { text: fmt(s.time_s * 1e3) }), el('td', { text: fmt(s.residual_rel) }),
    el('td', { text: String(s.history.res.length) + (s.history.thinned_from ? ` of ${s.history.thinned_from}` : '') }),
    el('td', { class: 'l muted', text: s.reason || '' }),
  ]))),
])]));

APP.append(el('h2', { text: 'Convergence' }));
const plotBox = el('div', { class: 'plots wide' });
APP.append(plotBox);
const curves = SOLVERS.map((s, k) => ({ label: s.name, xs: s.history.it, ys: s.history.res, color: PALETTE[k % PALETTE.length] }));
const plotted = curves.filter((c) => c.xs.length > 0).length;
joinedPlot(plotBox, 'relative natural-map residual per iteration (each solver\'s own unit: see "counted in")', curves,
  { log: true, xLabel: 'iteration', height: 320, legend: true, tolerance: P.tolerance });
if (!plotted) plotBox.append(el('p', { class: 'muted', text: 'No solver recorded a history.' }));

APP.append(el('h2', { text: 'Active set per pivot' }));
const activeBox = el('div', { class: 'panel' });
APP.append(activeBox);
const withActive = SOLVERS.filter((s) => s.history.extra);
function showActive(name) {
  const s = SOLVERS.find((x) => x.name === name);
  const pick = el('select', { onchange: (e) => showActive(e.target.value) }, SOLVERS.map((x) => {
    const o = el('option', { value: x.name, text: x.name });
    if (x.name === name) o.selected = true;
    return o;
  }));
  const parts = [el('div', {}, ['solver ', pick])];
  if (!s.history.extra) {
    parts.push(el('p', { class: 'muted', text: `${s.name}: active set not recorded.` }));
  } else {
    const h = s.history;
    parts.push(el('table', {}, [el('thead', {}, [el('tr', {}, [el('th', { text: 'pivot' }), el('th', { text: 'residual' }), el('th', { class: 'l', text: h.extra_key })])]),
      el('tbody', {}, h.extra.slice(0, 300).map((a, i) => el('tr', {}, [el('td', { text: String(h.it[i]) }), el('td', { text: fmt(h.res[i]) }),
        el('td', { class: 'l', text: Array.isArray(a) ? a.join(' ') : JSON.stringify(a) })])))]));
  }
  activeBox.replaceChildren(...parts);
}
showActive((withActive[0] || SOLVERS[0]).name);

APP.append(el('h2', { text: 'Final f and w per row' }));
const ROWS_SHOWN = Math.min(P.n, 500);
const frictionOf = new Map(P.friction.map(([row, normal, mu]) => [row, [normal, mu]]));
const bound = (x, lo) => (x === null ? (lo ? '−∞' : '∞') : fmt(x));
// A friction row's bounds are ±mu·f_normal: they depend on the solution, so the table says so
// instead of showing the stored placeholders.
const frictionBound = (i, lo) => {
  const [k, mu] = frictionOf.get(i);
  return `${lo ? '−' : '+'}${fmt(mu)}·f${k}`;
};
// A row is flagged when its natural-map component exceeds the tolerance times the scale of f.
function rowBad(s, i) {
  const f = s.f[i], w = s.w[i];
  if (f === null || f === undefined || w === null || w === undefined) return true;
  let lo = P.lo[i] === null ? -Infinity : P.lo[i], hi = P.hi[i] === null ? Infinity : P.hi[i];
  if (frictionOf.has(i)) {
    const [k, mu] = frictionOf.get(i);
    lo = -mu * Math.max(0, s.f[k] || 0); hi = -lo;
  }
  const scale = Math.max(1e-300, ...s.f.map((x) => Math.abs(x || 0)));
  const r = Math.abs(f - Math.min(hi, Math.max(lo, f - w)));
  return r > Math.max(1e-6, 100 * P.tolerance) * scale;
}
const head = [el('th', { text: 'row' }), el('th', { text: 'b' }), el('th', { text: 'lo' }), el('th', { text: 'hi' }), el('th', { class: 'l', text: 'friction of' })]
  .concat(SOLVERS.flatMap((s, k) => [el('th', { style: 'color:' + PALETTE[k % PALETTE.length], text: s.name + ' f' }), el('th', { style: 'color:' + PALETTE[k % PALETTE.length], text: 'w' })]));
const body = [];
for (let i = 0; i < ROWS_SHOWN; i++) {
  const fr = frictionOf.get(i);
  body.push(el('tr', {}, [el('td', { text: String(i) }), el('td', { text: fmt(P.b[i]) }), el('td', { text: fr ? frictionBound(i, true) : bound(P.lo[i], true) }), el('td', { text: fr ? frictionBound(i, false) : bound(P.hi[i], false) }),
    el('td', { class: 'l', text: fr ? `row ${fr[0]}, μ ${fr[1]}` : '' })]
    .concat(SOLVERS.flatMap((s) => {
      const cls = s.problem !== 'Coulomb cone' && s.f.length === P.n && rowBad(s, i) ? 'bad' : '';
      return [el('td', { class: cls, text: fmt(s.f[i]) }), el('td', { class: cls, text: fmt(s.w[i]) })];
    }))));
}
APP.append(el('div', { class: 'panel' }, [
  P.n > ROWS_SHOWN ? el('p', { class: 'muted', text: `first ${ROWS_SHOWN} of ${P.n} rows` }) : '',
  el('p', { class: 'muted', text: 'red: the row violates its complementarity condition (natural-map component above 100 × tolerance × ‖f‖∞). ' +
    'A friction row t of normal row k has bounds ±μ·f_k (shown as ±μ·fk): they move with the solution. Cone solvers are not flagged per row: they are judged on the cone, by the residual in the table above.' }),
  el('table', { id: 'rows' }, [el('thead', {}, [el('tr', {}, head)]), el('tbody', {}, body)]),
]));

publishState({ ready: true, solvers: SOLVERS.length, plotted, rows: P.n });
