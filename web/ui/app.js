// The rtplc console's front end: plain DOM, no framework, every text set as
// text (never as HTML). It talks only to the console's own routes (docs/web.md).
'use strict';

const $ = (id) => document.getElementById(id);
let session = null;       // {user, role, csrf, runtime}
let channels = new Map(); // label -> {row, desc}
let live = null;
let liveWants = null;     // what the open stream carries: null = every channel
let page = 'overview';
let lastFrame = 0;
let chartSteps = new Map(); // step flag label -> its box in the chart view
let pendingSwap = null;     // the upload the operator checked and may confirm
const ROLES = ['viewer', 'operator', 'engineer', 'admin'];
const may = (role) => session && ROLES.indexOf(session.role) >= ROLES.indexOf(role);

async function call(method, path, body) {
  const opt = { method, headers: {}, credentials: 'same-origin' };
  if (method === 'POST') {
    opt.headers['Content-Type'] = 'application/json';
    if (session) opt.headers['X-CSRF-Token'] = session.csrf;
    opt.body = JSON.stringify(body || {});
  }
  const res = await fetch(path, opt);
  let data = null;
  try { data = await res.json(); } catch (e) { data = { ok: false, error: { message: res.statusText } }; }
  if (res.status === 401 && path !== '/api/login') showLogin();
  return { status: res.status, data };
}

function el(tag, text, cls) {
  const e = document.createElement(tag);
  if (text !== undefined && text !== null) e.textContent = String(text);
  if (cls) e.className = cls;
  return e;
}

function showLogin() {
  session = null;
  if (live) { live.close(); live = null; }
  $('console').hidden = true;
  $('logout').hidden = true;
  $('who').textContent = '';
  $('login').hidden = false;
}

async function start() {
  const s = await call('GET', '/api/session');
  if (s.status !== 200) return showLogin();
  session = s.data;
  $('login').hidden = true;
  $('console').hidden = false;
  $('logout').hidden = false;
  $('who').textContent = session.user + ' (' + session.role + ')';
  $('runtime').textContent = session.runtime;
  document.querySelectorAll('.op').forEach((f) => { f.hidden = false; });
  $('set-form').hidden = !may('operator');
  $('force-form').hidden = !may('engineer');
  $('swap-form').hidden = !may('engineer');
  await loadChannels();
  await loadStatus();
  liveWants = shownChannels();
  openLive();
}

function fmt(v) {
  if (v === null || v === undefined) return '-';
  if (typeof v !== 'number') return String(v);
  return Math.abs(v) >= 1e6 || (v !== 0 && Math.abs(v) < 1e-3) ? v.toExponential(4) : String(Math.round(v * 1e6) / 1e6);
}

async function loadChannels() {
  const r = await call('GET', '/api/channels');
  if (r.status !== 200) return;
  const body = $('channels').tBodies[0];
  body.replaceChildren();
  channels.clear();
  const sets = $('set-label'), forces = $('force-label');
  sets.replaceChildren(); forces.replaceChildren();
  for (const c of r.data.channels) {
    const tr = el('tr');
    tr.dataset.testid = 'channel-' + c.label;
    const cells = {
      label: el('td', c.label), dir: el('td', c.hmi ? c.dir + ' (HMI)' : c.dir), addr: el('td', c.channel),
      value: el('td', fmt(c.value), 'num'), quality: el('td', c.quality), age: el('td', '', 'num'),
      writer: el('td', c.writer + (c.on_bad ? ', on bad: ' + c.on_bad : '')),
    };
    cells.value.dataset.testid = 'value-' + c.label;
    cells.quality.dataset.testid = 'quality-' + c.label;
    Object.values(cells).forEach((td) => tr.appendChild(td));
    body.appendChild(tr);
    channels.set(c.label, { row: tr, cells, desc: c });
    if (c.dir === 'setpoint') sets.appendChild(el('option', c.label));
    else forces.appendChild(el('option', c.label));
  }
  filter();
}

async function loadStatus() {
  const [r, t] = await Promise.all([call('GET', '/api/status'), call('GET', '/api/stats')]);
  if (r.status !== 200 || t.status !== 200) { setStale(true); return; }
  const st = r.data.result.status, stats = t.data.result.stats;
  const timing = new Map((stats.tasks || []).map((x) => [x.name, x]));
  const us = (ns) => fmt(ns / 1000);
  const cards = $('tasks');
  cards.replaceChildren();
  const tasks = $('swap-task');
  const chosen = tasks.value;
  tasks.replaceChildren();
  const charts = $('chart-task');
  const chartChosen = charts.value;
  charts.replaceChildren();
  const varTasks = $('vars-task');
  const varsChosen = varTasks.value;
  varTasks.replaceChildren();
  for (const task of st.tasks || []) {
    const c = el('div', null, 'card');
    c.dataset.testid = 'task-' + task.name;
    c.appendChild(el('h3', task.name));
    const facts = el('div', null, 'facts');
    const x = timing.get(task.name);
    const lines = ['state ' + task.state + ', period ' + fmt(task.period_ns / 1e6) + ' ms',
      'program ' + (task.file || '?') + (task.program ? ' (' + String(task.program).slice(0, 12) + ', ' + task.origin + ')' : '')];
    if (x) {
      lines.push('wake last/p99/max ' + [x.wake_ns.last, x.wake_ns.p99, x.wake_ns.max].map(us).join(' / ') + ' us');
      lines.push('exec last/p99/max ' + [x.exec_ns.last, x.exec_ns.p99, x.exec_ns.max].map(us).join(' / ') + ' us');
      lines.push('overruns ' + x.overruns + ' of ' + x.cycles + ' cycles');
    }
    for (const l of lines) facts.appendChild(el('div', l));
    c.appendChild(facts);
    cards.appendChild(c);
    tasks.appendChild(el('option', task.name));
    varTasks.appendChild(el('option', task.name));
    if (task.active_steps) charts.appendChild(el('option', task.name));
  }
  if (chosen) tasks.value = chosen;
  if (chartChosen) charts.value = chartChosen;
  if (varsChosen) varTasks.value = varsChosen;
  const forced = st.forced || [];
  $('forces').hidden = forced.length === 0;
  $('forces').textContent = forced.length + ' FORCED';
  $('forced-banner').hidden = forced.length === 0;
  $('forced-banner').textContent = 'FORCED: ' + forced.map((f) => f.label + ' = ' + fmt(f.value)).join(', ');
  if (stats.runtime) $('uptime').textContent = 'up ' + fmt(Math.round(stats.runtime.uptime_ns / 1e9)) + ' s';
  const links = $('links').tBodies[0];
  links.replaceChildren();
  for (const l of stats.links || []) {
    const tr = el('tr');
    let gauges = Object.entries(l.gauges || {}).map(([k, v]) => k + ' ' + v).join(', ');
    if (l.last_error) gauges += (gauges ? '; ' : '') + 'last error ' + Math.round(l.last_error_age_s) + ' s ago: ' + l.last_error;
    [l.name, l.kind, l.peer, l.state, l.errors, gauges].forEach((v) => tr.appendChild(el('td', v)));
    links.appendChild(tr);
  }
}

function setStale(stale) {
  $('stale').hidden = !stale;
  $('state').textContent = stale ? 'STALE' : 'RUN';
  $('state').className = 'state ' + (stale ? 'stale' : 'run');
  channels.forEach((c) => c.row.classList.toggle('stale', stale));
}

// The channels this page shows: the overview's rows the search leaves, the
// chart's step flags, none elsewhere (the stream then says only whether the
// runtime is alive). Null when that is every channel.
function shownChannels() {
  let labels = [];
  if (page === 'overview') labels = [...channels.values()].filter((c) => !c.row.hidden).map((c) => c.desc.label);
  else if (page === 'chart') labels = [...chartSteps.keys()];
  else if (page === 'editor') labels = editorLiveLabels();
  return labels.length === channels.size && labels.length > 0 ? null : labels.sort();
}

// Streams only what is shown: a new stream (whose first frame is whole) when
// that changes.
function resubscribe() {
  const wants = shownChannels();
  if (live && JSON.stringify(wants) === JSON.stringify(liveWants)) return;
  liveWants = wants;
  openLive();
}

function openLive() {
  if (live) live.close();
  const wants = liveWants === undefined ? null : liveWants;
  live = new EventSource('/api/live' + (wants === null ? '' : '?channels=' + encodeURIComponent(wants.join(','))));
  live.onmessage = (ev) => {
    const f = JSON.parse(ev.data);
    lastFrame = Date.now();
    setStale(!f.alive);
    for (const v of f.values) {
      if (page === 'editor') editorLiveValue(v);
      const step = chartSteps.get(v.label);
      if (step) step.classList.toggle('active', v.value !== 0);
      const c = channels.get(v.label);
      if (!c) continue;
      c.cells.value.textContent = fmt(v.value);
      c.cells.quality.textContent = v.forced && v.quality === 'forced' ? 'FORCED' : v.quality;
      c.cells.quality.className = 'q-' + v.quality;
      c.cells.age.textContent = v.age_s === null ? '-' : v.age_s.toFixed(2) + ' s';
    }
  };
  live.onerror = () => { setStale(true); };
}

// A console that stops hearing from its server says so rather than freeze.
setInterval(() => {
  if (session && lastFrame && Date.now() - lastFrame > 3000) setStale(true);
}, 1000);
setInterval(() => { if (session) loadStatus(); }, 5000);

function filter() {
  const q = $('search').value.trim().toLowerCase();
  channels.forEach((c) => {
    // An HMI variable's channel is found by "hmi" too (its direction reads "setpoint (HMI)").
    c.row.hidden = q !== '' && !(c.desc.label.toLowerCase().includes(q) || c.desc.channel.toLowerCase().includes(q) ||
                                 c.cells.dir.textContent.toLowerCase().includes(q));
  });
  clearTimeout(filter.timer);
  if (live) filter.timer = setTimeout(resubscribe, 300);  // once typing pauses
}

function said(r) {
  const out = $('op-result');
  if (r.data && r.data.ok) {
    out.className = '';
    out.textContent = r.data.result.text;
  } else {
    out.className = 'error';
    out.textContent = (r.data && r.data.error && r.data.error.message) || ('HTTP ' + r.status);
  }
  loadStatus();
}

document.addEventListener('DOMContentLoaded', () => {
  $('login-form').addEventListener('submit', async (e) => {
    e.preventDefault();
    const r = await call('POST', '/api/login', { user: $('login-user').value, password: $('login-password').value });
    $('login-password').value = '';
    if (r.status !== 200) { $('login-error').textContent = r.data.error.message; return; }
    $('login-error').textContent = '';
    start();
  });
  $('logout').addEventListener('click', async () => { await call('POST', '/api/logout'); showLogin(); });
  document.querySelectorAll('nav button').forEach((b) => b.addEventListener('click', () => {
    document.querySelectorAll('nav button').forEach((x) => x.classList.toggle('active', x === b));
    document.querySelectorAll('.page').forEach((p) => { p.hidden = p.id !== 'page-' + b.dataset.page; });
    page = b.dataset.page;
    document.body.classList.toggle('printing-editor', page === 'editor');
    resubscribe();
    if (b.dataset.page === 'audit') loadAudit();
    if (b.dataset.page === 'jitter') loadJitter();
    if (b.dataset.page === 'trend') fillTrendLabels();
    if (b.dataset.page === 'chart') loadChart();
    if (b.dataset.page === 'variables') pollVariables();
    if (b.dataset.page === 'operations') loadPrograms();
    if (b.dataset.page === 'editor') editorOpen();
  }));
  $('chart-task').addEventListener('change', loadChart);
  $('vars-task').addEventListener('change', pollVariables);
  $('swap-task').addEventListener('change', loadPrograms);
  $('search').addEventListener('input', filter);
  $('set-form').addEventListener('submit', async (e) => {
    e.preventDefault();
    said(await call('POST', '/api/set', { label: $('set-label').value, value: $('set-value').value }));
  });
  $('force-form').addEventListener('submit', async (e) => {
    e.preventDefault();
    const label = $('force-label').value, value = $('force-value').value;
    if (!window.confirm('Force ' + label + ' to ' + value + '? Tasks and drivers use this value until it is unforced.')) return;
    said(await call('POST', '/api/force', { label, value }));
  });
  $('unforce').addEventListener('click', async () => said(await call('POST', '/api/unforce', { label: $('force-label').value })));
  $('swap-form').addEventListener('submit', async (e) => {
    e.preventDefault();
    const file = $('swap-file').files[0];
    if (!file) return;
    const task = $('swap-task').value;
    const upload = { task, name: file.name, source: await file.text() };
    const r = await call('POST', '/api/swap/check', upload);
    said(r);
    pendingSwap = r.data && r.data.ok ? upload : null;
    $('swap-confirm').hidden = !pendingSwap;
    $('swap-cancel').hidden = !pendingSwap;
  });
  const endSwap = () => { pendingSwap = null; $('swap-confirm').hidden = true; $('swap-cancel').hidden = true; };
  $('swap-cancel').addEventListener('click', () => { endSwap(); $('op-result').textContent = 'swap cancelled; nothing changed'; });
  $('swap-confirm').addEventListener('click', async () => {
    const upload = pendingSwap;
    endSwap();
    if (!upload) return;
    said(await call('POST', '/api/swap', upload));
    loadPrograms();
  });
  $('rollback').addEventListener('click', async () => {
    const task = $('swap-task').value;
    if (!window.confirm('Roll task ' + task + ' back to its previous program?')) return;
    said(await call('POST', '/api/rollback', { task }));
    loadPrograms();
  });
  $('audit-refresh').addEventListener('click', loadAudit);
  $('jitter-refresh').addEventListener('click', loadJitter);
  $('trend-start').addEventListener('click', startTrend);
  $('trend-stop').addEventListener('click', stopTrend);
  $('trend-pause').addEventListener('click', () => {
    trend.paused = !trend.paused;
    $('trend-pause').textContent = trend.paused ? 'resume' : 'pause';
    drawTrend();
  });
  $('trend-window').addEventListener('change', drawTrend);
  $('trend-csv').addEventListener('click', trendCsv);
  start();
});

async function loadAudit() {
  const r = await call('GET', '/api/audit?lines=200');
  $('audit').textContent = r.status === 200 ? r.data.result.text : (r.data.error && r.data.error.message);
}

// One histogram as SVG bars: x the bucket's lower bound on a log axis (us),
// y log10(count + 1). Built with DOM calls, labels as text.
const SVG = 'http://www.w3.org/2000/svg';
function svgEl(tag, attrs, text) {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
  if (text !== undefined) e.textContent = text;
  return e;
}

function histogram(title, series, cls, testid) {
  const box = el('div', null, 'hist');
  box.dataset.testid = testid;
  box.appendChild(el('h3', title + ': ' + series.count + ' cycles, p50 ' + fmt(series.p50_ns / 1000) + ' us, p99 ' +
    fmt(series.p99_ns / 1000) + ' us, p99.9 ' + fmt(series.p99_9_ns / 1000) + ' us, max ' + fmt(series.max_ns / 1000) + ' us'));
  const W = 1000, H = 160, L = 40, B = 20;
  const svg = svgEl('svg', { viewBox: `0 0 ${W} ${H}`, preserveAspectRatio: 'none' });
  const bs = series.buckets;
  if (bs.length) {
    const lo = Math.log10(Math.max(bs[0][0], 100)), hi = Math.log10(Math.max(bs[bs.length - 1][0] * 1.1, bs[0][0] * 10, 1000));
    const top = Math.log10(Math.max(...bs.map((b) => b[1])) + 1);
    const x = (ns) => L + (W - L - 5) * (Math.log10(Math.max(ns, 100)) - lo) / (hi - lo);
    for (let i = 0; i < bs.length; i++) {
      const [ns, n] = bs[i];
      const x0 = x(ns), x1 = Math.max(x0 + 2, x(ns * 1.0625));
      const h = (H - B - 5) * Math.log10(n + 1) / top;
      svg.appendChild(svgEl('rect', { x: x0, y: H - B - h, width: x1 - x0, height: h, class: 'bar ' + cls }));
    }
    svg.appendChild(svgEl('line', { x1: L, y1: H - B, x2: W, y2: H - B, class: 'axis' }));
    for (let d = Math.ceil(lo); d <= Math.floor(hi); d++) {
      const ns = Math.pow(10, d);
      svg.appendChild(svgEl('text', { x: x(ns), y: H - 4 }, ns >= 1e6 ? ns / 1e6 + ' ms' : ns / 1e3 + ' us'));
    }
  }
  box.appendChild(svg);
  return box;
}

async function loadJitter() {
  const r = await call('GET', '/api/jitter');
  const out = $('jitter');
  out.replaceChildren();
  if (r.status !== 200) { out.appendChild(el('p', r.data.error && r.data.error.message, 'error')); return; }
  for (const t of r.data.tasks) {
    out.appendChild(el('h2', t.name + ' (period ' + fmt(t.period_ns / 1e6) + ' ms, ' + t.policy + ' ' + t.priority + ')'));
    out.appendChild(histogram('wake latency', t.wake, 'wake', 'jitter-wake-' + t.name));
    out.appendChild(histogram('execution time', t.exec, 'exec', 'jitter-exec-' + t.name));
  }
}

// ---- Trend: a trace of one task's cycles, drawn on a canvas ----
const COLORS = ['#3b6fb6', '#c0262d', '#17803d', '#a85f00', '#6b2fb3', '#0f7f8f', '#8a8a00', '#555'];
const trend = { id: null, columns: [], rows: [], lost: 0, paused: false, source: null, task: '', period_ns: 0 };
const TREND_KEEP = 600000;  // rows kept for drawing and CSV (10 min at 1 ms)

function fillTrendLabels() {
  const sel = $('trend-labels');
  if (sel.options.length) return;
  channels.forEach((c) => sel.appendChild(el('option', c.desc.label)));
}

async function startTrend() {
  const labels = Array.from($('trend-labels').selectedOptions).map((o) => o.value);
  if (!labels.length) { $('trend-info').textContent = 'pick one or more channels'; return; }
  const r = await call('POST', '/api/trend', { labels });
  if (r.status !== 200) { $('trend-info').textContent = (r.data.error && r.data.error.message) || ('HTTP ' + r.status); return; }
  Object.assign(trend, { id: r.data.id, columns: r.data.columns.map((c) => c.label), rows: [], lost: 0, paused: false,
    task: r.data.task, period_ns: r.data.period_ns });
  $('trend-stop').disabled = false; $('trend-pause').disabled = false; $('trend-csv').disabled = false;
  $('trend-start').disabled = true;
  const legend = $('trend-legend');
  legend.replaceChildren();
  trend.columns.forEach((c, i) => { const e = el('span', c); e.style.setProperty('--swatch', COLORS[i]); legend.appendChild(e); });
  trend.source = new EventSource('/api/trend/stream?id=' + encodeURIComponent(trend.id));
  trend.source.onmessage = (ev) => {
    const f = JSON.parse(ev.data);
    for (const row of f.samples) trend.rows.push(row);
    if (trend.rows.length > TREND_KEEP) trend.rows.splice(0, trend.rows.length - TREND_KEEP);
    trend.lost = f.lost;
    const last = trend.rows.length ? trend.rows[trend.rows.length - 1] : null;
    $('trend-info').textContent = 'task ' + trend.task + ', every ' + fmt(trend.period_ns / 1e6) + ' ms: ' +
      trend.rows.length + ' cycles' + (trend.lost ? ', ' + trend.lost + ' LOST' : ', none lost') +
      (last ? ', t = ' + last[0].toFixed(2) + ' s' : '');
    if (!trend.paused) drawTrend();
  };
  trend.source.addEventListener('ended', (ev) => { endTrend('ended: ' + JSON.parse(ev.data).why); });
  trend.source.onerror = () => { if (trend.source && trend.source.readyState === EventSource.CLOSED) endTrend('the stream closed'); };
}

function endTrend(why) {
  if (trend.source) trend.source.close();
  trend.source = null;
  trend.id = null;
  $('trend-stop').disabled = true; $('trend-pause').disabled = true; $('trend-start').disabled = false;
  if (why) $('trend-info').textContent += ' (' + why + ')';
}

async function stopTrend() {
  const id = trend.id;
  endTrend('stopped');
  if (id) await call('POST', '/api/trend/stop', { id });
}

function drawTrend() {
  const cv = $('trend-plot');
  const ctx = cv.getContext('2d');
  const W = cv.width, H = cv.height, L = 60, R = 10, T = 10, B = 24;
  ctx.clearRect(0, 0, W, H);
  const rows = trend.rows;
  if (!rows.length) return;
  const span = Number($('trend-window').value);
  const tEnd = rows[rows.length - 1][0], tStart = tEnd - span;
  let first = rows.length - 1;
  while (first > 0 && rows[first - 1][0] >= tStart) first--;
  let lo = Infinity, hi = -Infinity;
  for (let i = first; i < rows.length; i++) {
    for (let k = 3; k < rows[i].length; k++) { const v = rows[i][k]; if (v !== null) { lo = Math.min(lo, v); hi = Math.max(hi, v); } }
  }
  if (!isFinite(lo)) return;
  if (hi - lo < 1e-9) { hi += 1; lo -= 1; }
  const pad = (hi - lo) * 0.05; lo -= pad; hi += pad;
  const x = (t) => L + (W - L - R) * (t - tStart) / span;
  const y = (v) => T + (H - T - B) * (1 - (v - lo) / (hi - lo));
  ctx.strokeStyle = '#d8dce2'; ctx.fillStyle = '#66707c'; ctx.font = '12px sans-serif';
  for (let g = 0; g <= 4; g++) {
    const v = lo + (hi - lo) * g / 4;
    ctx.beginPath(); ctx.moveTo(L, y(v)); ctx.lineTo(W - R, y(v)); ctx.stroke();
    ctx.fillText(fmt(Number(v.toPrecision(4))), 4, y(v) + 4);
  }
  ctx.fillText(tStart.toFixed(1) + ' s', L, H - 6);
  ctx.fillText(tEnd.toFixed(1) + ' s', W - R - 50, H - 6);
  for (let k = 3; k < rows[first].length; k++) {
    ctx.strokeStyle = COLORS[k - 3]; ctx.lineWidth = 1.5; ctx.beginPath();
    let pen = false;
    for (let i = first; i < rows.length; i++) {
      const v = rows[i][k];
      // A record that was lost (a gap in record numbers) breaks the line: nothing is drawn across it.
      const gap = i > first && rows[i][2] !== rows[i - 1][2] + 1;
      if (v === null || gap) { pen = false; if (v === null) continue; }
      if (!pen) { ctx.moveTo(x(rows[i][0]), y(v)); pen = true; } else ctx.lineTo(x(rows[i][0]), y(v));
    }
    ctx.stroke();
  }
}

function trendCsv() {
  const lines = ['# rtplc trend of task ' + trend.task + ' (every cycle; ' + trend.lost + ' records lost)',
    ['t_s', 'cycle', 'record'].concat(trend.columns).join(',')];
  for (const r of trend.rows) lines.push(r.map((v) => (v === null ? '' : String(v))).join(','));
  const url = URL.createObjectURL(new Blob([lines.join('\n') + '\n'], { type: 'text/csv' }));
  const a = document.createElement('a');
  a.href = url; a.download = 'trend-' + trend.task + '.csv';
  document.body.appendChild(a); a.click(); a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}

// The program store of the task chosen on the operations page.
async function loadPrograms() {
  const task = $('swap-task').value;
  const body = $('programs').tBodies[0];
  if (!task) return;
  const r = await call('GET', '/api/program?task=' + encodeURIComponent(task));
  body.replaceChildren();
  if (r.status !== 200) return;
  const res = r.data.result;
  const versions = res.history.length ? res.history : [{ hash: res.running, time: '', origin: res.origin }];
  for (const v of versions.slice().reverse()) {
    const tr = el('tr');
    tr.dataset.testid = 'program-' + v.hash;
    tr.appendChild(el('td', v.hash + (v.hash === res.running ? ' (running)' : '')));
    tr.appendChild(el('td', v.time));
    tr.appendChild(el('td', v.origin));
    const td = el('td');
    const b = el('button', 'view');
    b.type = 'button';
    b.addEventListener('click', async () => {
      const s = await call('GET', '/api/program?task=' + encodeURIComponent(task) + '&hash=' + encodeURIComponent(v.hash));
      const pre = $('program-source');
      pre.hidden = false;
      pre.textContent = s.status === 200 ? s.data.result.source : (s.data.error && s.data.error.message);
    });
    td.appendChild(b);
    tr.appendChild(td);
    body.appendChild(tr);
  }
}

// The Variables page: the chosen task's watch (GET /api/watch) while the page
// is shown, the program's variables only ("Main.level"; not the compiler's
// temporaries "scopy.$5", constants "k:1", "plcopen.true" or "dao@..."), a
// STRING's value as its quoted text.
let varsTimer = null;
async function pollVariables() {
  clearTimeout(varsTimer);
  if (page !== 'variables') return;
  const task = $('vars-task').value;
  if (task) {
    const r = await call('GET', '/api/watch?task=' + encodeURIComponent(task));
    if (page !== 'variables') return;
    const body = $('vars').tBodies[0];
    if (r.status !== 200) {
      $('vars-info').textContent = (r.data && r.data.error && r.data.error.message) || 'no answer';
    } else if (r.data.result.pending) {
      $('vars-info').textContent = 'asking the task for its values';
    } else {
      const res = r.data.result, q = $('vars-search').value.toLowerCase();
      $('vars-info').textContent = 'cycle ' + res.cycle;
      body.replaceChildren();
      for (const b of res.blocks) {
        if (/[$@:]/.test(b.name) || b.name.startsWith('plcopen.')) continue;
        if (q && !b.name.toLowerCase().includes(q)) continue;
        const tr = el('tr');
        tr.dataset.testid = 'var-' + b.name;
        tr.appendChild(el('td', b.name));
        const text = typeof b.value === 'string';
        tr.appendChild(el('td', text ? "'" + b.value + "'" : fmt(b.value), text ? 'str' : 'num'));
        tr.appendChild(el('td', b.quality, 'q-' + b.quality));
        body.appendChild(tr);
      }
    }
  }
  varsTimer = setTimeout(pollVariables, 500);
}

// An SFC chart drawn as SVG: steps top to bottom in the order written, each
// transition as a bar under its source step with its condition beside it;
// a transition to a step that is not the next one runs up or down a lane on
// the right.
async function loadChart() {
  const task = $('chart-task').value;
  const box = $('chart');
  chartSteps = new Map();
  box.replaceChildren();
  $('chart-info').textContent = '';
  if (!task) { $('chart-info').textContent = 'no SFC task in this runtime'; return; }
  const r = await call('GET', '/api/chart?task=' + encodeURIComponent(task));
  if (r.status !== 200) { $('chart-info').textContent = (r.data.error && r.data.error.message) || ('HTTP ' + r.status); return; }
  const c = r.data;
  $('chart-info').textContent = 'chart ' + c.chart + ', program ' + c.program + ', ' + c.steps.length + ' steps, ' +
    c.transitions.length + ' transitions';
  box.appendChild(chartSvg(c, chartSteps));
  for (const [label, g] of chartSteps) {
    const ch = channels.get(label);
    if (ch) g.classList.toggle('active', ch.cells.value.textContent !== '0');
  }
  resubscribe();
}

// The chart's SVG; `steps` gets each step's flag label -> its group (lit when active).
function chartSvg(c, steps) {
  const W = 170, H = 38, GAP = 44, X = 40;
  const row = new Map(c.steps.map((s, i) => [s.name, i]));
  const y = (i) => 16 + i * (H + GAP);
  let lanes = 0;
  const svg = svgEl('svg', { viewBox: '0 0 900 ' + (y(c.steps.length) + 10), role: 'img' });
  c.transitions.forEach((t) => {
    const from = row.get(t.from[0]), to = row.get(t.to[0]);
    if (from === undefined || to === undefined) return;
    const by = y(from) + H + GAP / 2;
    const cx = X + W / 2;
    svg.appendChild(svgEl('line', { x1: cx, y1: y(from) + H, x2: cx, y2: by, class: 'link' }));
    svg.appendChild(svgEl('line', { x1: cx - 16, y1: by, x2: cx + 16, y2: by, class: 'bar' }));
    svg.appendChild(svgEl('text', { x: cx + 24, y: by + 4, class: 'cond' }, t.name + ': ' + t.when));
    if (to === from + 1) {
      svg.appendChild(svgEl('line', { x1: cx, y1: by, x2: cx, y2: y(to), class: 'link' }));
    } else {
      const lx = X + W + 300 + 18 * lanes++;
      svg.appendChild(svgEl('polyline', {
        points: [cx, by, cx, by + 8, lx, by + 8, lx, y(to) - 8, cx, y(to) - 8, cx, y(to)].join(' '), class: 'link jump' }));
    }
  });
  c.steps.forEach((s, i) => {
    const g = svgEl('g', { class: 'step', 'data-testid': 'step-' + s.name });
    g.appendChild(svgEl('rect', { x: X, y: y(i), width: W, height: H, rx: 3 }));
    if (s.initial) g.appendChild(svgEl('rect', { x: X + 4, y: y(i) + 4, width: W - 8, height: H - 8, rx: 2, class: 'inner' }));
    g.appendChild(svgEl('text', { x: X + 12, y: y(i) + H / 2 + 5, class: 'name' }, s.name));
    if (s.actions.length) g.appendChild(svgEl('text', { x: X + W + 10, y: y(i) + H / 2 + 5, class: 'act' }, s.actions.join(', ')));
    svg.appendChild(g);
    steps.set(s.label, g);
  });
  return svg;
}
