// The FBD editor page (docs/editor.md): the seed's block grid as SVG, a
// palette from the compiler's registry, drawing with the mouse or the keys
// the seed names (arrows move the block cursor, Enter chooses, Ins connects),
// and the real compiler's verdict after every change, drawn on the blocks.
// The diagram is the server's (POST /api/fbd/to-diagram); this page edits
// its written fields only and asks the server for text, layout and checks.
'use strict';

const ed = {
  registry: null,   // name -> block spec (GET /api/blocks)
  diagram: null,    // as /api/fbd/to-diagram gives it
  history: [], future: [],
  cursor: { col: 0, row: 0 },
  selected: null,   // index of the selected block
  armed: null,      // the palette's chosen kind, placed by Enter or a click
  connectFrom: null, // Ins pressed on this block: the next Ins connects it
  verdict: null,    // the last /api/fbd/check answer
  clipboard: null,
  timer: 0, checkSeq: 0,
  drag: null,
};
const CW = 140, CH = 86, BW = 104, IOW = 126, BH = 50;

function edEl(tag, attrs, text) {
  const e = document.createElementNS('http://www.w3.org/2000/svg', tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

async function editorOpen() {
  if (!ed.registry) {
    const r = await call('GET', '/api/blocks');
    if (r.status !== 200) { $('ed-verdict').textContent = 'the palette could not be loaded: HTTP ' + r.status; return; }
    ed.registry = new Map(r.data.blocks.map((b) => [b.name, b]));
    buildPalette();
  }
  if (!ed.diagram) newDiagram(7, 5);
  loadWorkspaceList();
  draw();
}

function newDiagram(cols, rows) {
  ed.diagram = { format: 'rtplc-fbd', version: 1, grid: { cols, rows }, period_s: 0.1, blocks: [], macros: [] };
  ed.history = []; ed.future = []; ed.selected = null; ed.cursor = { col: 0, row: 0 }; ed.verdict = null;
  $('ed-period').value = '0.1';
  buildPalette();
  afterChange();
}

// ---- the palette ----------------------------------------------------------
function buildPalette() {
  if (!ed.registry) return;
  const q = $('ed-search').value.trim().toLowerCase();
  const box = $('ed-palette');
  box.replaceChildren();
  const groups = new Map();
  for (const b of ed.registry.values()) {
    if (q && !(b.name.includes(q) || b.summary.toLowerCase().includes(q))) continue;
    if (!groups.has(b.group)) groups.set(b.group, []);
    groups.get(b.group).push({ name: b.name, title: b.summary, macro: false });
  }
  for (const m of (ed.diagram ? ed.diagram.macros : [])) {
    if (q && !m.name.toLowerCase().includes(q)) continue;
    if (!groups.has('macro')) groups.set('macro', []);
    groups.get('macro').push({ name: m.name, title: 'macro ' + m.name + ' (' + m.analog + '|' + m.digital + '|' + m.params + ')', macro: true });
  }
  for (const [g, items] of groups) {
    box.appendChild(el('h4', g));
    for (const it of items) {
      const b = el('button', it.name, 'pal' + (ed.armed && ed.armed.name === it.name ? ' armed' : ''));
      b.type = 'button';
      b.title = it.title;
      b.dataset.testid = 'palette-' + it.name;
      b.addEventListener('click', () => {
        ed.armed = ed.armed && ed.armed.name === it.name ? null : it;
        buildPalette();
        showHelp(it);
        $('ed-sheet').focus();
      });
      box.appendChild(b);
    }
  }
}

function showHelp(it) {
  const h = $('ed-help');
  h.replaceChildren();
  if (!it) return;
  const spec = ed.registry.get(it.name);
  if (!spec) { h.appendChild(el('p', it.title)); return; }
  h.appendChild(el('b', spec.name));
  h.appendChild(el('p', spec.summary));
  const pins = spec.inputs.map((i) => i.name + ':' + i.kind[0].toUpperCase() + (i.optional ? '?' : '')).join(', ');
  if (pins) h.appendChild(el('p', 'inputs ' + pins));
  for (const p of spec.params) {
    h.appendChild(el('p', p.name + ' — ' + p.meaning + (p.min !== null || p.max !== null ? ' [' + (p.min ?? '') + ', ' + (p.max ?? '') + ']' : '')));
  }
  h.appendChild(el('p', spec.contract, 'muted'));
}

// ---- the model ------------------------------------------------------------
const isValueRef = (a) => a && 'ref' in a && (a.ref === null || /^[FDMN]/.test(a.ref));

function written() {
  const d = ed.diagram;
  return {
    format: 'rtplc-fbd', version: 1, grid: d.grid, period_s: d.period_s,
    blocks: d.blocks.map((b) => ({ id: b.id, kind: b.kind, macro: b.macro, args: b.args, col: b.col, row: b.row })),
    macros: d.macros,
  };
}

function change(fn) {
  ed.history.push(JSON.stringify(written()));
  if (ed.history.length > 200) ed.history.shift();
  ed.future = [];
  fn();
  afterChange();
}

function restore(json) {
  const w = JSON.parse(json);
  ed.diagram.blocks = w.blocks; ed.diagram.macros = w.macros; ed.diagram.period_s = w.period_s; ed.diagram.grid = w.grid;
  if (ed.selected !== null && ed.selected >= ed.diagram.blocks.length) ed.selected = null;
  afterChange();
}
function undo() { if (ed.history.length) { ed.future.push(JSON.stringify(written())); restore(ed.history.pop()); } }
function redo() { if (ed.future.length) { ed.history.push(JSON.stringify(written())); restore(ed.future.pop()); } }

function afterChange() {
  draw();
  showProps();
  // The verdict shown is always this diagram's: none until the check answers.
  const v = $('ed-verdict');
  v.className = '';
  v.textContent = 'checking…';
  v.dataset.identity = '';
  ++ed.checkSeq;  // an answer still on its way is about an older diagram
  clearTimeout(ed.timer);
  ed.timer = setTimeout(runCheck, 250);
}

function blockAt(col, row) { return ed.diagram.blocks.findIndex((b) => b.col === col && b.row === row); }

function nextId(letter) {
  let n = 0;
  for (const b of ed.diagram.blocks) if (b.id) n = Math.max(n, Number(b.id.slice(1)));
  return letter + (n + 1);
}

function newBlock(it, col, row) {
  if (it.macro) {
    const m = ed.diagram.macros.find((x) => x.name === it.name);
    const args = [];
    for (let k = 0; k < m.analog + m.digital; ++k) args.push({ ref: null });
    for (let k = 0; k < m.params; ++k) args.push({ number: 0 });
    return { id: nextId('F'), kind: it.name, macro: true, args, col, row };
  }
  const s = ed.registry.get(it.name);
  const count = ed.diagram.blocks.filter((b) => b.kind === s.name).length;
  const label = (s.name.toUpperCase() + (count + 1)).slice(0, 8);
  let args = [];
  if (s.signature === 'device_in') args = [{ device: 'p0' }, { device: 'd0' }, { device: 'c' + count }, { string: label }];
  else if (s.signature === 'setpoint') args = [{ device: 'd0' }, { device: 'c' + count }, { number: 0 }, { string: label }];
  else if (s.signature === 'device_out') args = [{ ref: null }, { device: 'p0' }, { device: 'd0' }, { device: 'c' + count }, { string: label }];
  else {
    for (let k = 0; k < s.inputs.length; ++k) if (!s.inputs[k].optional) args.push({ ref: null });
    for (const p of s.params) if (!p.optional) args.push({ number: p.default ?? (p.min !== null && p.min > 0 ? p.min : 0) });
  }
  const id = s.has_output ? nextId(s.out_kind === 'digital' ? 'D' : 'F') : null;
  return { id, kind: s.name, macro: false, args, col, row };
}

function place(col, row) {
  if (!ed.armed || blockAt(col, row) >= 0) return false;
  const b = newBlock(ed.armed, col, row);
  change(() => { ed.diagram.blocks.push(b); ed.selected = ed.diagram.blocks.length - 1; });
  return true;
}

function removeBlock(i) {
  change(() => {
    const gone = ed.diagram.blocks[i];
    ed.diagram.blocks.splice(i, 1);
    if (gone.id) for (const b of ed.diagram.blocks) for (const a of b.args) if (a.ref === gone.id) a.ref = null;
    ed.selected = null;
  });
}

// Connects block `from`'s output to input `arg` of block `to` (the first open
// one when `arg` is undefined).
function connect(from, to, arg) {
  const src = ed.diagram.blocks[from], dst = ed.diagram.blocks[to];
  if (!src || !dst || !src.id) return;
  const pins = dst.args.map((a, k) => (isValueRef(a) ? k : -1)).filter((k) => k >= 0);
  if (arg === undefined) arg = pins.find((k) => dst.args[k].ref === null) ?? pins[0];
  if (arg === undefined) return;
  change(() => { dst.args[arg] = { ref: src.id }; });
}

// Inputs not yet connected: the text cannot say them, so the page does.
function openPins() {
  const out = [];
  ed.diagram.blocks.forEach((b, i) => b.args.forEach((a, k) => { if (isValueRef(a) && a.ref === null) out.push([i, k]); }));
  return out;
}

async function runCheck() {
  const seq = ++ed.checkSeq;
  const open = openPins();
  if (open.length) {
    ed.verdict = {
      compiles: false, identity: null, rendered: open.map(([i, k]) => {
        const b = ed.diagram.blocks[i];
        return 'input ' + (k + 1) + ' of ' + b.kind + (b.id ? ' ' + b.id : '') + ' is not connected';
      }).join('\n'),
      diagnostics: open.map(([i, k]) => ({ block: i, arg: k, macro: null, severity: 'error', message: 'not connected' })),
    };
  } else {
    const r = await call('POST', '/api/fbd/check', { diagram: written(), file: $('ed-name').value || 'untitled.fbd' });
    if (seq !== ed.checkSeq) return;  // a newer change is being checked
    ed.verdict = r.status === 200 ? r.data : { compiles: false, rendered: (r.data.error && r.data.error.message) || 'HTTP ' + r.status, diagnostics: [] };
  }
  const v = $('ed-verdict');
  v.className = ed.verdict.compiles ? 'ok' : 'error';
  v.textContent = ed.verdict.compiles ? 'compiles — program identity ' + ed.verdict.identity : ed.verdict.rendered;
  v.dataset.identity = ed.verdict.identity || '';
  draw();
}

// ---- drawing --------------------------------------------------------------
function blockBox(b) {
  const s = !b.macro && ed.registry.get(b.kind);
  const w = s && s.signature !== 'compute' ? IOW : BW;
  return { x: b.col * CW + (CW - w) / 2, y: b.row * CH + (CH - BH) / 2, w, h: BH };
}
function inPins(b) {
  const box = blockBox(b);
  const ks = b.args.map((a, k) => (isValueRef(a) ? k : -1)).filter((k) => k >= 0);
  return ks.map((k, j) => ({ k, x: box.x + box.w * (j + 1) / (ks.length + 1), y: box.y }));
}
function outPin(b) { const box = blockBox(b); return { x: box.x + box.w / 2, y: box.y + box.h }; }

function draw() {
  const svg = $('ed-sheet');
  if (!svg || !ed.diagram) return;
  const d = ed.diagram;
  let cols = d.grid.cols, rows = d.grid.rows;
  for (const b of d.blocks) { cols = Math.max(cols, b.col + 2); rows = Math.max(rows, b.row + 2); }
  cols = Math.max(cols, ed.cursor.col + 1); rows = Math.max(rows, ed.cursor.row + 1);
  svg.setAttribute('viewBox', '0 0 ' + cols * CW + ' ' + rows * CH);
  svg.setAttribute('width', cols * CW);
  svg.setAttribute('height', rows * CH);
  svg.replaceChildren();
  const errs = new Map();
  for (const x of (ed.verdict ? ed.verdict.diagnostics : [])) {
    if (x.macro || x.block === null || x.block === undefined) continue;
    if (!errs.has(x.block)) errs.set(x.block, []);
    errs.get(x.block).push(x);
  }
  for (let r = 0; r < rows; ++r) {
    for (let c = 0; c < cols; ++c) {
      const cell = edEl('rect', { x: c * CW, y: r * CH, width: CW, height: CH, class: 'cell' + (c >= d.grid.cols || r >= d.grid.rows ? ' past' : '') });
      cell.addEventListener('click', () => { ed.cursor = { col: c, row: r }; if (!place(c, r)) { ed.selected = null; draw(); showProps(); } });
      svg.appendChild(cell);
    }
  }
  const byId = new Map();
  d.blocks.forEach((b, i) => { if (b.id && !byId.has(b.id)) byId.set(b.id, i); });
  // Wires first, under the blocks; a one-cycle feedback reference dashed.
  d.blocks.forEach((b, i) => {
    for (const p of inPins(b)) {
      const a = b.args[p.k];
      if (!a.ref || !byId.has(a.ref)) continue;
      const j = byId.get(a.ref), src = d.blocks[j], o = outPin(src);
      const feedback = j >= i;
      let path;
      if (src.row < b.row) {
        const my = (o.y + p.y) / 2;
        path = 'M' + o.x + ' ' + o.y + ' C' + o.x + ' ' + my + ' ' + p.x + ' ' + my + ' ' + p.x + ' ' + p.y;
      } else {
        const side = Math.max(blockBox(src).x + blockBox(src).w, blockBox(b).x + blockBox(b).w) + 12;
        path = 'M' + o.x + ' ' + o.y + ' v10 H' + side + ' V' + (p.y - 10) + ' H' + p.x + ' V' + p.y;
      }
      svg.appendChild(edEl('path', { d: path, class: 'wire' + (feedback ? ' fb' : ''), 'data-testid': 'wire-' + a.ref + '-' + i + '-' + p.k }));
    }
  });
  d.blocks.forEach((b, i) => {
    const box = blockBox(b);
    const s = !b.macro && ed.registry.get(b.kind);
    const g = edEl('g', { class: 'blk g-' + (b.macro ? 'macro' : s ? s.group : 'unknown') + (errs.has(i) ? ' err' : '') + (ed.selected === i ? ' sel' : '') + (ed.connectFrom === i ? ' from' : ''), 'data-testid': 'block-' + (b.id || 'out-' + i) });
    g.appendChild(edEl('rect', { x: box.x, y: box.y, width: box.w, height: box.h, rx: 4 }));
    g.appendChild(edEl('text', { x: box.x + 6, y: box.y + 16, class: 'kind' }, b.kind));
    if (b.id) g.appendChild(edEl('text', { x: box.x + box.w - 6, y: box.y + 16, class: 'fno' }, b.id));
    const label = b.args.find((a) => 'string' in a);
    const params = b.args.filter((a) => 'number' in a).map((a) => fmt(a.number)).join(', ');
    g.appendChild(edEl('text', { x: box.x + 6, y: box.y + 34, class: 'sub' }, label ? label.string : (b.macro ? 'macro ' : '') + params));
    const dev = b.args.filter((a) => 'device' in a).map((a) => a.device).join('.');
    if (dev) g.appendChild(edEl('text', { x: box.x + 6, y: box.y + 46, class: 'dev' }, dev));
    if (errs.has(i)) g.appendChild(edEl('title', {}, errs.get(i).map((x) => x.message).join('\n')));
    g.addEventListener('mousedown', (e) => { if (e.button === 0) ed.drag = { kind: 'move', i }; });
    g.addEventListener('click', (e) => { e.stopPropagation(); ed.selected = i; ed.cursor = { col: b.col, row: b.row }; draw(); showProps(); });
    for (const p of inPins(b)) {
      const bad = (errs.get(i) || []).some((x) => x.arg === p.k);
      const pin = edEl('circle', { cx: p.x, cy: p.y, r: 5, class: 'pin in' + (b.args[p.k].ref === null ? ' open' : '') + (bad ? ' bad' : ''), 'data-testid': 'pin-' + i + '-' + p.k });
      pin.addEventListener('mouseup', () => { if (ed.drag && ed.drag.kind === 'wire') connect(ed.drag.from, i, p.k); ed.drag = null; });
      g.appendChild(pin);
    }
    if (b.id) {
      const o = outPin(b);
      const pin = edEl('circle', { cx: o.x, cy: o.y, r: 5, class: 'pin out', 'data-testid': 'out-' + b.id });
      pin.addEventListener('mousedown', (e) => { e.stopPropagation(); ed.drag = { kind: 'wire', from: i }; });
      g.appendChild(pin);
    }
    svg.appendChild(g);
  });
  const c = ed.cursor;
  svg.appendChild(edEl('rect', { x: c.col * CW + 2, y: c.row * CH + 2, width: CW - 4, height: CH - 4, class: 'cursor', 'data-testid': 'cursor' }));
  $('ed-status').textContent = d.blocks.length + ' blocks; cursor ' + c.col + ',' + c.row +
    (ed.armed ? '; Enter places ' + ed.armed.name : '') + (ed.connectFrom !== null ? '; Ins on a block connects ' + d.blocks[ed.connectFrom].id : '');
}

function sheetCell(e) {
  const svg = $('ed-sheet');
  const r = svg.getBoundingClientRect();
  const vb = svg.viewBox.baseVal;
  return { col: Math.floor(((e.clientX - r.left) * vb.width / r.width) / CW), row: Math.floor(((e.clientY - r.top) * vb.height / r.height) / CH) };
}

// ---- the selected block's properties ----------------------------------------
function showProps() {
  const box = $('ed-props');
  box.replaceChildren();
  if (ed.selected === null || !ed.diagram.blocks[ed.selected]) { box.appendChild(el('p', 'no block selected', 'muted')); return; }
  const i = ed.selected, b = ed.diagram.blocks[i];
  const s = !b.macro && ed.registry.get(b.kind);
  box.appendChild(el('h4', (b.macro ? 'MACRO ' : '') + b.kind + (b.id ? ' — ' + b.id : '')));
  if (b.id) box.appendChild(el('p', 'runs ' + (i + 1) + ' of ' + ed.diagram.blocks.length, 'muted'));
  const ids = ed.diagram.blocks.filter((x) => x.id).map((x) => x.id);
  let input = 0, param = 0;
  b.args.forEach((a, k) => {
    let name = 'argument ' + (k + 1), field;
    if (isValueRef(a)) {
      name = s ? (s.inputs[input] ? s.inputs[input].name : 'in') : 'input ' + (input + 1);
      input++;
      field = el('select');
      field.appendChild(el('option', '(not connected)'));
      field.lastChild.value = '';
      for (const id of ids) { const o = el('option', id); o.value = id; field.appendChild(o); }
      field.value = a.ref || '';
      field.addEventListener('change', () => change(() => { b.args[k] = { ref: field.value || null }; }));
    } else if ('number' in a || ('ref' in a && /^P/.test(a.ref))) {
      const p = s && s.params[param];
      name = p ? p.name : 'parameter ' + (param + 1);
      param++;
      field = el('input');
      field.inputMode = 'decimal';
      field.value = 'number' in a ? String(a.number) : a.ref;
      if (p) field.title = p.meaning + (p.min !== null || p.max !== null ? ' [' + (p.min ?? '') + ', ' + (p.max ?? '') + ']' : '');
      field.addEventListener('change', () => {
        const v = field.value.trim();
        if (/^P\d+$/.test(v)) change(() => { b.args[k] = { ref: v }; });
        else if (v !== '' && Number.isFinite(Number(v))) change(() => { b.args[k] = { number: Number(v) }; });
        else field.value = 'number' in a ? String(a.number) : a.ref;
      });
    } else if ('device' in a) {
      name = { p: 'processor', d: 'device', c: 'channel' }[a.device[0]];
      field = el('input');
      field.value = a.device;
      field.addEventListener('change', () => {
        const v = field.value.trim();
        if (new RegExp('^' + a.device[0] + '\\d+$').test(v)) change(() => { b.args[k] = { device: v }; });
        else field.value = a.device;
      });
    } else if ('string' in a) {
      name = 'label';
      field = el('input');
      field.value = a.string;
      field.addEventListener('change', () => {
        const v = field.value.trim();
        if (v && !/["\x00-\x1f]/.test(v)) change(() => { b.args[k] = { string: v }; });
        else field.value = a.string;
      });
    }
    if (!field) return;
    field.dataset.testid = 'prop-' + k;
    const l = el('label', name + ' ');
    l.appendChild(field);
    box.appendChild(l);
  });
  const del = el('button', 'delete block');
  del.type = 'button';
  del.addEventListener('click', () => removeBlock(i));
  box.appendChild(del);
}

// ---- files ----------------------------------------------------------------
async function loadWorkspaceList() {
  const r = await call('GET', '/api/workspace');
  const sel = $('ed-files');
  sel.replaceChildren();
  $('ed-workspace').textContent = r.status === 200 ? 'workspace ' + r.data.dir : 'no workspace (rtplc web --workspace DIR): upload and download';
  if (r.status !== 200) return;
  for (const f of r.data.files) sel.appendChild(el('option', f.name));
}

async function openText(text, layout, name) {
  const r = await call('POST', '/api/fbd/to-diagram', { text, layout, file: name });
  if (r.status !== 200) { $('ed-verdict').className = 'error'; $('ed-verdict').textContent = r.data.error.message; return; }
  ed.diagram = r.data.diagram;
  ed.history = []; ed.future = []; ed.selected = null; ed.cursor = { col: 0, row: 0 };
  $('ed-name').value = name;
  $('ed-period').value = ed.diagram.period_s === null ? '' : String(ed.diagram.period_s);
  buildPalette();
  afterChange();
}

function opening(name) {
  const v = $('ed-verdict');
  v.className = '';
  v.textContent = 'opening ' + name + '…';
  v.dataset.identity = '';
  ++ed.checkSeq;
}

async function openFromWorkspace() {
  const name = $('ed-files').value;
  if (!name) return;
  opening(name);
  const r = await call('GET', '/api/workspace/file?name=' + encodeURIComponent(name));
  if (r.status !== 200) { $('ed-verdict').textContent = r.data.error.message; return; }
  await openText(r.data.text, r.data.layout, name);
}

async function saveTo(target) {
  const r = await call('POST', '/api/fbd/to-text', { diagram: written() });
  if (r.status !== 200) { $('ed-saved').textContent = r.data.error.message; return; }
  let name = $('ed-name').value.trim() || 'untitled.fbd';
  if (!name.endsWith('.fbd')) name += '.fbd';
  if (target === 'download') {
    for (const [body, fname] of [[r.data.text, name], [JSON.stringify(r.data.layout, null, 1) + '\n', name + '.layout']]) {
      const a = document.createElement('a');
      a.href = URL.createObjectURL(new Blob([body], { type: 'text/plain' }));
      a.download = fname;
      a.click();
      URL.revokeObjectURL(a.href);
    }
    $('ed-saved').textContent = 'downloaded ' + name + ' and ' + name + '.layout';
    return;
  }
  const s = await call('POST', '/api/workspace/save', { name, text: r.data.text, layout: r.data.layout });
  $('ed-saved').textContent = s.status === 200 ? 'saved ' + name + ' and its layout' : s.data.error.message;
  if (s.status === 200) loadWorkspaceList();
}

// ---- keys: the seed's block cursor ----------------------------------------
function editorKey(e) {
  const d = ed.diagram, c = ed.cursor;
  const at = blockAt(c.col, c.row);
  const ctrl = e.ctrlKey || e.metaKey;
  if (ctrl && e.key === 'z') { undo(); }
  else if (ctrl && (e.key === 'y' || e.key === 'Z')) { redo(); }
  else if (ctrl && e.key === 'c') { if (at >= 0) ed.clipboard = JSON.parse(JSON.stringify(d.blocks[at])); }
  else if (ctrl && e.key === 'v') {
    if (ed.clipboard && at < 0) {
      const b = JSON.parse(JSON.stringify(ed.clipboard));
      b.col = c.col; b.row = c.row;
      if (b.id) b.id = nextId(b.id[0]);
      change(() => { d.blocks.push(b); ed.selected = d.blocks.length - 1; });
    }
  } else if (e.key === 'ArrowLeft') { c.col = Math.max(0, c.col - 1); }
  else if (e.key === 'ArrowRight') { c.col += 1; }
  else if (e.key === 'ArrowUp') { c.row = Math.max(0, c.row - 1); }
  else if (e.key === 'ArrowDown') { c.row += 1; }
  else if (e.key === 'Enter') {
    if (at >= 0) { ed.selected = at; showProps(); } else place(c.col, c.row);
  } else if (e.key === 'Insert' || e.key === 'i') {
    if (at < 0) return;
    if (ed.connectFrom === null) { if (d.blocks[at].id) ed.connectFrom = at; }
    else { const from = ed.connectFrom; ed.connectFrom = null; connect(from, at); }
  } else if (e.key === 'Delete') { if (at >= 0) removeBlock(at); }
  else if (e.key === 'Escape') { ed.armed = null; ed.connectFrom = null; buildPalette(); }
  else return;
  e.preventDefault();
  draw();
  // Keep the cursor in view: the sheet scrolls past one screen, as the seed's does.
  const wrap = $('ed-wrap');
  const x = c.col * CW, y = c.row * CH;
  if (x < wrap.scrollLeft || x + CW > wrap.scrollLeft + wrap.clientWidth) wrap.scrollLeft = x - CW;
  if (y < wrap.scrollTop || y + CH > wrap.scrollTop + wrap.clientHeight) wrap.scrollTop = y - CH;
}

function editorWire() {
  const svg = $('ed-sheet');
  svg.addEventListener('keydown', editorKey);
  svg.addEventListener('mouseup', (e) => {
    const drag = ed.drag;
    ed.drag = null;
    if (!drag || drag.kind !== 'move') return;
    const to = sheetCell(e), b = ed.diagram.blocks[drag.i];
    if (!b || (to.col === b.col && to.row === b.row) || blockAt(to.col, to.row) >= 0) return;
    change(() => { b.col = to.col; b.row = to.row; ed.cursor = to; });
  });
  $('ed-search').addEventListener('input', buildPalette);
  $('ed-new').addEventListener('click', () => newDiagram(Math.max(1, Number($('ed-cols').value) || 7), Math.max(1, Number($('ed-rows').value) || 5)));
  $('ed-open').addEventListener('click', openFromWorkspace);
  $('ed-upload').addEventListener('change', async () => {
    const f = $('ed-upload').files[0];
    if (f) { opening(f.name); await openText(await f.text(), null, f.name); }
  });
  $('ed-save').addEventListener('click', () => saveTo('workspace'));
  $('ed-download').addEventListener('click', () => saveTo('download'));
  $('ed-undo').addEventListener('click', undo);
  $('ed-redo').addEventListener('click', redo);
  $('ed-period').addEventListener('change', () => {
    const v = $('ed-period').value.trim();
    change(() => { ed.diagram.period_s = v === '' ? null : Number(v); });
  });
}
document.addEventListener('DOMContentLoaded', editorWire);
