// The FBD editor page (docs/editor.md): the seed's block grid as SVG, a
// palette from the compiler's registry, drawing with the mouse or the keys
// the seed names (arrows move the block cursor, Enter chooses, Ins connects),
// and the real compiler's verdict after every change, drawn on the blocks;
// macros made from a selection, opened and expanded; simulation against the
// plant models of rtplc sim; print and SVG with a title block; online, a
// running task's program with live values on its I/O wires, swapped from here.
// The diagram is the server's (POST /api/fbd/to-diagram); this page edits
// its written fields only and asks the server for text, layout and checks.
'use strict';

const ed = {
  registry: null,   // name (or alias) -> block spec (GET /api/blocks)
  blocks: [],       // the specs, in the registry's order
  diagram: null,    // as /api/fbd/to-diagram gives it
  history: [], future: [],
  cursor: { col: 0, row: 0 },
  view: null,       // null: the program; else the name of the macro being edited
  selected: null,   // index of the selected block (its properties are shown)
  sel: new Set(),   // the selection (Shift+click, Space): moved, made a macro
  armed: null,      // the palette's chosen kind, placed by Enter or a click
  connectFrom: null, // Ins pressed on this block: the next Ins connects it
  verdict: null,    // the last /api/fbd/check answer
  clipboard: null,
  timer: 0, checkSeq: 0,
  drag: null,
  sim: null,        // the last simulation's answer
  online: null,     // { task, running, values: label -> live value }
  pendingSwap: null,
  liveTimer: 0,
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
    // Both spellings a block accepts (derv and the seed's deriv) name it: the
    // text keeps the one chosen, as the compiler's image does.
    ed.blocks = r.data.blocks;
    ed.registry = new Map(r.data.blocks.map((b) => [b.name, b]));
    for (const b of r.data.blocks) if (b.alias) ed.registry.set(b.alias, b);
    buildPalette();
  }
  if (!ed.diagram) newDiagram(7, 5);
  loadWorkspaceList();
  loadTasks();
  draw();
}

function newDiagram(cols, rows) {
  ed.diagram = { format: 'rtplc-fbd', version: 1, grid: { cols, rows }, period_s: 0.1, blocks: [], macros: [] };
  ed.history = []; ed.future = []; ed.cursor = { col: 0, row: 0 }; ed.verdict = null;
  clearSelection(); ed.view = null;
  showReadOnly(false);
  $('ed-period').value = '0.1';
  $('ed-name').value = 'untitled.fbd';
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
  for (const b of ed.blocks) {
    for (const name of [b.name, b.alias].filter(Boolean)) {
      if (q && !(name.includes(q) || b.summary.toLowerCase().includes(q))) continue;
      if (!groups.has(b.group)) groups.set(b.group, []);
      groups.get(b.group).push({ name, title: b.summary + (name !== b.name ? ' (' + b.name + ' spelled ' + name + ')' : ''), macro: false });
    }
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

// The sheet being edited: the program's blocks, or one macro's body.
function macroOf(name) { return ed.diagram.macros.find((m) => m.name === name); }
function cur() { return ed.view === null ? ed.diagram.blocks : macroOf(ed.view).blocks; }
// Inside a macro its analog and digital formals are the sheet's inputs.
function formals() {
  return ed.view === null ? [] : macroOf(ed.view).formals.filter((f) => /^[MN]/.test(f));
}

function written() {
  const d = ed.diagram;
  const strip = (bs) => bs.map((b) => ({ id: b.id, kind: b.kind, macro: b.macro, args: b.args, col: b.col, row: b.row }));
  return {
    format: 'rtplc-fbd', version: 1, grid: d.grid, period_s: d.period_s,
    blocks: strip(d.blocks),
    macros: d.macros.map((m) => ({
      name: m.name, declared: m.declared, defined: m.defined, analog: m.analog, digital: m.digital,
      params: m.params, formals: m.formals, return: m.return, blocks: strip(m.blocks),
    })),
  };
}

function clearSelection() { ed.selected = null; ed.sel = new Set(); }
function selectOnly(i) { ed.selected = i; ed.sel = new Set(i === null ? [] : [i]); }

function change(fn) {
  ed.history.push(JSON.stringify({ w: written(), view: ed.view }));
  if (ed.history.length > 200) ed.history.shift();
  ed.future = [];
  fn();
  afterChange();
}

function restore(json) {
  const { w, view } = JSON.parse(json);
  ed.diagram.blocks = w.blocks; ed.diagram.macros = w.macros; ed.diagram.period_s = w.period_s; ed.diagram.grid = w.grid;
  ed.view = view && macroOf(view) ? view : null;
  clearSelection();
  afterChange();
}
const snapshot = () => JSON.stringify({ w: written(), view: ed.view });
function undo() { if (ed.history.length) { ed.future.push(snapshot()); restore(ed.history.pop()); } }
function redo() { if (ed.future.length) { ed.history.push(snapshot()); restore(ed.future.pop()); } }

function afterChange() {
  draw();
  showProps();
  showView();
  // The verdict shown is always this diagram's: none until the check answers.
  const v = $('ed-verdict');
  v.className = '';
  v.textContent = 'checking…';
  v.dataset.identity = '';
  ++ed.checkSeq;  // an answer still on its way is about an older diagram
  clearTimeout(ed.timer);
  ed.timer = setTimeout(runCheck, 250);
}

function blockAt(col, row) { return cur().findIndex((b) => b.col === col && b.row === row); }

// The next free name with `letter` on the sheet (inside a macro, past its formals).
function nextId(letter) {
  let n = 0;
  for (const b of cur()) if (b.id && b.id[0] === letter) n = Math.max(n, Number(b.id.slice(1)));
  if (ed.view === null) for (const b of cur()) if (b.id) n = Math.max(n, Number(b.id.slice(1)));
  for (const f of (ed.view === null ? [] : macroOf(ed.view).formals)) n = Math.max(n, Number(f.slice(1)));
  return letter + (n + 1);
}
const idLetter = (digital) => (ed.view === null ? (digital ? 'D' : 'F') : (digital ? 'N' : 'M'));

function newBlock(it, col, row) {
  if (it.macro) {
    const m = macroOf(it.name);
    const args = [];
    for (let k = 0; k < m.analog + m.digital; ++k) args.push({ ref: null });
    for (let k = 0; k < m.params; ++k) args.push({ number: 0 });
    const ret = m.return || 'M';
    return { id: nextId(idLetter(ret[0] === 'N')), kind: it.name, macro: true, args, col, row };
  }
  const s = ed.registry.get(it.name);
  const count = cur().filter((b) => b.kind === it.name).length;
  const label = (s.name.toUpperCase() + (count + 1)).slice(0, 8);
  let args = [];
  if (s.signature === 'device_in') args = [{ device: 'p0' }, { device: 'd0' }, { device: 'c' + count }, { string: label }];
  else if (s.signature === 'setpoint') args = [{ device: 'd0' }, { device: 'c' + count }, { number: 0 }, { string: label }];
  else if (s.signature === 'device_out') args = [{ ref: null }, { device: 'p0' }, { device: 'd0' }, { device: 'c' + count }, { string: label }];
  else {
    for (let k = 0; k < s.inputs.length; ++k) if (!s.inputs[k].optional) args.push({ ref: null });
    for (const p of s.params) if (!p.optional) args.push({ number: p.default ?? (p.min !== null && p.min > 0 ? p.min : 0) });
  }
  const id = s.has_output ? nextId(idLetter(s.out_kind === 'digital')) : null;
  return { id, kind: it.name, macro: false, args, col, row };
}

function place(col, row) {
  if (!ed.armed || blockAt(col, row) >= 0) return false;
  const b = newBlock(ed.armed, col, row);
  change(() => { cur().push(b); selectOnly(cur().length - 1); });
  return true;
}

function removeBlock(i) {
  change(() => {
    const gone = cur()[i];
    cur().splice(i, 1);
    if (gone.id) for (const b of cur()) for (const a of b.args) if (a.ref === gone.id) a.ref = null;
    clearSelection();
  });
}

// Renames a block (its F-number) and every reference to it.
function renameBlock(i, id) {
  const b = cur()[i];
  const want = new RegExp('^' + b.id[0] + '[1-9][0-9]*$');
  if (!want.test(id)) return b.id[0] + ' and a number: the kind of value stays (' + b.id[0] + ')';
  if (cur().some((x) => x.id === id) || formals().includes(id)) return id + ' is taken';
  change(() => {
    const old = b.id;
    b.id = id;
    for (const x of cur()) for (const a of x.args) if (a.ref === old) a.ref = id;
    if (ed.view !== null && macroOf(ed.view).return === old) macroOf(ed.view).return = id;
  });
  return null;
}

// Connects `ref` (a block's output or a macro formal) to input `arg` of block
// `to` (the first open one when `arg` is undefined).
function connectRef(ref, to, arg) {
  const dst = cur()[to];
  if (!dst || !ref) return;
  const pins = dst.args.map((a, k) => (isValueRef(a) ? k : -1)).filter((k) => k >= 0);
  if (arg === undefined) arg = pins.find((k) => dst.args[k].ref === null) ?? pins[0];
  if (arg === undefined) return;
  change(() => { dst.args[arg] = { ref }; });
}
function connect(from, to, arg) { const src = cur()[from]; if (src && src.id) connectRef(src.id, to, arg); }

// Inputs not yet connected, on every sheet: the text cannot say them, so the page does.
function openPins() {
  const out = [];
  const scan = (bs, macro) => bs.forEach((b, i) => b.args.forEach((a, k) => { if (isValueRef(a) && a.ref === null) out.push({ macro, i, k, b }); }));
  scan(ed.diagram.blocks, null);
  for (const m of ed.diagram.macros) scan(m.blocks, m.name);
  return out;
}

async function runCheck() {
  const seq = ++ed.checkSeq;
  const open = openPins();
  if (open.length) {
    ed.verdict = {
      compiles: false, identity: null, rendered: open.map(({ macro, k, b }) =>
        'input ' + (k + 1) + ' of ' + b.kind + (b.id ? ' ' + b.id : '') + (macro ? ' in macro ' + macro : '') + ' is not connected').join('\n'),
      diagnostics: open.map(({ macro, i, k }) => ({ block: i, arg: k, macro, severity: 'error', message: 'not connected' })),
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

// ---- macros: from a selection, opened, expanded ----------------------------
// The selection becomes MACRO NAME(a|d|p): its inputs from outside become the
// formals M1.. (analog) and N1.. (digital) in the order first read, the numbers
// ticked become P1.., the one result read outside is RETURNed, and the
// selection is replaced by one call at the place of its last block (so every
// block still sees what it saw). Block names keep their numbers (F7 -> M7)
// unless a formal has taken it.
function macroCandidates() {
  const bs = ed.diagram.blocks;
  return [...ed.sel].sort((a, b) => a - b).flatMap((i) => bs[i].args.map((a, k) => ({ i, k, a })).filter((x) => 'number' in x.a).map((x) => ({
    i: x.i, k: x.k, value: x.a.number,
    name: bs[x.i].kind + ' ' + (bs[x.i].id || '') + ' ' + paramName(bs[x.i], x.k),
  })));
}
function paramName(b, k) {
  const s = !b.macro && ed.registry.get(b.kind);
  const nth = b.args.slice(0, k).filter((a) => 'number' in a || ('ref' in a && /^P/.test(a.ref))).length;
  return s && s.params[nth] ? s.params[nth].name : 'parameter ' + (nth + 1);
}

function defineMacro(name, paramKeys) {
  if (ed.view !== null) return 'macros are made on the program sheet';
  if (!/^[A-Z][A-Z0-9_]{0,15}$/.test(name)) return 'a macro name is 1 to 16 capitals, digits or _, starting with a letter';
  // A call says MACRO NAME(...), so a macro may share a block's name (the seed's PID and pid).
  if (macroOf(name)) return 'this program already has a macro ' + name;
  const bs = ed.diagram.blocks;
  const idx = [...ed.sel].sort((a, b) => a - b);
  if (!idx.length) return 'select the blocks first (Shift+click, or Space on the sheet)';
  for (const i of idx) {
    const s = !bs[i].macro && ed.registry.get(bs[i].kind);
    if (s && s.signature !== 'compute') return bs[i].kind + ' is an I/O block: I/O stays in the program and its value is passed in';
  }
  const inSel = new Set(idx);
  const first = idx[0], last = idx[idx.length - 1];
  const ids = new Set(idx.map((i) => bs[i].id).filter(Boolean));
  const usedOutside = new Set();
  bs.forEach((b, i) => { if (!inSel.has(i)) for (const a of b.args) if (a.ref && ids.has(a.ref)) usedOutside.add(a.ref); });
  if (usedOutside.size > 1) return 'a macro returns one value, and ' + [...usedOutside].join(', ') + ' are read outside the selection';
  const retId = usedOutside.size ? [...usedOutside][0] : bs[last].id;
  if (!retId) return 'the selection computes nothing to return';
  for (let i = first + 1; i < last; ++i) {
    if (inSel.has(i)) continue;
    if (bs[i].args.some((a) => a.ref === retId)) return bs[i].kind + ' ' + (bs[i].id || '') + ' runs inside the selection and reads its result: select it too or move it after';
    if (bs[i].id && idx.some((j) => j < i && bs[j].args.some((a) => a.ref === bs[i].id))) return 'the selection reads ' + bs[i].id + ', which runs between its blocks: select it too';
  }
  // Formals: outside inputs in the order first read.
  const ext = [];
  for (const i of idx) for (const a of bs[i].args) if (isValueRef(a) && a.ref && !ids.has(a.ref) && !ext.includes(a.ref)) ext.push(a.ref);
  const analog = ext.filter((r) => /^[FM]/.test(r)), digital = ext.filter((r) => /^[DN]/.test(r));
  const map = new Map();
  analog.forEach((r, k) => map.set(r, 'M' + (k + 1)));
  digital.forEach((r, k) => map.set(r, 'N' + (k + 1)));
  const taken = new Set(map.values());
  for (const i of idx) {
    const id = bs[i].id;
    if (!id) continue;
    const letter = id[0] === 'D' ? 'N' : 'M';
    let n = Number(id.slice(1));
    while (taken.has(letter + n)) ++n;
    taken.add(letter + n);
    map.set(id, letter + n);
  }
  const params = [];
  const body = idx.map((i) => {
    const b = JSON.parse(JSON.stringify(bs[i]));
    b.id = b.id ? map.get(b.id) : null;
    b.args = b.args.map((a, k) => {
      if (isValueRef(a) && a.ref) return { ref: map.get(a.ref) };
      if ('number' in a && paramKeys.has(i + ':' + k)) { params.push(a.number); return { ref: 'P' + params.length }; }
      return a;
    });
    return b;
  });
  const macro = {
    name, declared: true, defined: true, analog: analog.length, digital: digital.length, params: params.length,
    formals: [...analog.map((r) => map.get(r)), ...digital.map((r) => map.get(r)), ...params.map((_, k) => 'P' + (k + 1))],
    return: map.get(retId), blocks: body,
  };
  // Its body's layout: the selection's own, shifted under the formals' row.
  const minCol = Math.min(...body.map((b) => b.col)), minRow = Math.min(...body.map((b) => b.row));
  for (const b of body) { b.col -= minCol; b.row = b.row - minRow + 1; }
  const retBlock = bs[idx.find((i) => bs[i].id === retId)];
  const callBlock = {
    id: retId, kind: name, macro: true,
    args: [...analog.map((r) => ({ ref: r })), ...digital.map((r) => ({ ref: r })), ...params.map((v) => ({ number: v }))],
    col: retBlock.col, row: retBlock.row,
  };
  change(() => {
    const keep = bs.filter((_, i) => !inSel.has(i) || i === last);
    const at = keep.indexOf(bs[last]);
    keep[at] = callBlock;
    ed.diagram.blocks = keep;
    ed.diagram.macros.push(macro);
    selectOnly(at);
  });
  buildPalette();
  return null;
}

// The call replaced by its body: formals by the call's arguments, parameters by
// its numbers, the body's names by free names of the program.
function expandMacro(i) {
  const bs = ed.diagram.blocks, call = bs[i], m = macroOf(call.kind);
  if (!m) return;
  const map = new Map();
  m.formals.forEach((f, k) => map.set(f, call.args[k]));
  let n = 0;
  for (const b of bs) if (b.id) n = Math.max(n, Number(b.id.slice(1)));
  for (const b of m.blocks) if (b.id) map.set(b.id, { ref: (b.id === m.return ? call.id : (b.id[0] === 'N' ? 'D' : 'F') + (++n)) });
  const body = m.blocks.map((b, k) => ({
    id: b.id ? map.get(b.id).ref : null, kind: b.kind, macro: b.macro,
    args: b.args.map((a) => ('ref' in a && a.ref && map.has(a.ref) ? JSON.parse(JSON.stringify(map.get(a.ref))) : a)),
    col: -1, row: -1, k,
  }));
  change(() => {
    // Cells: the call's, then free cells to its right and below.
    const used = new Set(bs.filter((_, j) => j !== i).map((b) => b.col + ',' + b.row));
    let c = call.col, r = call.row;
    for (const b of body.slice().reverse()) {
      while (used.has(c + ',' + r)) { c += 1; if (c >= call.col + 4) { c = call.col; r += 1; } }
      b.col = c; b.row = r; used.add(c + ',' + r);
      delete b.k;
    }
    bs.splice(i, 1, ...body);
    clearSelection();
  });
}

// `call`: the call it was opened from, whose instance the wires show online
// (its blocks run as CALL.M3, CALL.M4, ...).
function openMacro(name, call) {
  if (!macroOf(name)) return;
  ed.viewCall = ed.view === null ? call || null : null;
  ed.view = name; clearSelection(); ed.cursor = { col: 0, row: 0 }; ed.connectFrom = null;
  draw(); showProps(); showView();
}
function closeMacro() { ed.view = null; clearSelection(); ed.connectFrom = null; draw(); showProps(); showView(); }

// The bar over the sheet: which sheet this is, a macro's RETURN, the way back.
function showView() {
  const box = $('ed-view');
  box.replaceChildren();
  if (ed.view === null) {
    box.appendChild(el('span', 'program' + (ed.sel.size > 1 ? ' — ' + ed.sel.size + ' blocks selected' : '')));
    return;
  }
  const m = macroOf(ed.view);
  box.appendChild(el('b', 'MACRO ' + m.name + '(' + m.analog + '|' + m.digital + '|' + m.params + ')'));
  box.appendChild(el('span', ' formals ' + m.formals.join(', ') + ' · RETURN '));
  const ret = el('select');
  ret.dataset.testid = 'ed-return';
  for (const b of m.blocks) if (b.id) { const o = el('option', b.id); o.value = b.id; ret.appendChild(o); }
  ret.value = m.return || '';
  ret.addEventListener('change', () => change(() => { m.return = ret.value; }));
  box.appendChild(ret);
  const back = el('button', 'back to the program');
  back.type = 'button';
  back.dataset.testid = 'ed-back';
  back.addEventListener('click', closeMacro);
  box.appendChild(document.createTextNode(' '));
  box.appendChild(back);
}

// The "macro from selection" panel: a name and which numbers become parameters.
function showMacroForm() {
  const box = $('ed-macro-form');
  box.replaceChildren();
  box.hidden = false;
  if (ed.view !== null || ed.sel.size === 0) {
    box.appendChild(el('p', 'select blocks of the program first: Shift+click them, or Space on each with the cursor', 'muted'));
    return;
  }
  box.appendChild(el('h4', 'macro from ' + ed.sel.size + ' blocks'));
  const l = el('label', 'name ');
  const name = el('input');
  name.dataset.testid = 'ed-macro-name';
  name.value = 'MACRO' + (ed.diagram.macros.length + 1);
  l.appendChild(name);
  box.appendChild(l);
  box.appendChild(el('p', 'parameters (P1, P2, … in this order):', 'muted'));
  const ticks = [];
  for (const c of macroCandidates()) {
    const t = el('label', '');
    const cb = el('input');
    cb.type = 'checkbox';
    cb.checked = true;
    cb.dataset.testid = 'ed-macro-param-' + c.i + '-' + c.k;
    t.appendChild(cb);
    t.appendChild(document.createTextNode(' ' + c.name + ' = ' + fmt(c.value)));
    box.appendChild(t);
    ticks.push([c, cb]);
  }
  const ok = el('button', 'make the macro');
  ok.type = 'button';
  ok.dataset.testid = 'ed-macro-make';
  const said = el('p', '', 'error');
  ok.addEventListener('click', () => {
    const keys = new Set(ticks.filter(([, cb]) => cb.checked).map(([c]) => c.i + ':' + c.k));
    const err = defineMacro(name.value.trim(), keys);
    if (err) said.textContent = err; else { box.hidden = true; $('ed-sheet').focus(); }
  });
  box.appendChild(ok);
  box.appendChild(said);
  name.focus();
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
// A macro's formal: a small input on the sheet's top row.
function formalBox(k) { return { x: k * CW + (CW - 60) / 2, y: 8, w: 60, h: 22 }; }
function formalPin(k) { const f = formalBox(k); return { x: f.x + f.w / 2, y: f.y + f.h }; }

// The label whose live value a block's output wire carries while online: an
// input's or set-point's own channel, or the channel of the output block it feeds.
function wireLabel(b) {
  if (ed.view !== null || !ed.online) return null;
  const s = !b.macro && ed.registry.get(b.kind);
  const label = (x) => { const a = x.args.find((y) => 'string' in y); return a ? a.string : null; };
  if (s && (s.signature === 'device_in' || s.signature === 'setpoint')) return label(b);
  if (!b.id) return null;
  const out = ed.diagram.blocks.find((x) => { const t = !x.macro && ed.registry.get(x.kind); return t && t.signature === 'device_out' && x.args[0].ref === b.id; });
  return out ? label(out) : null;
}

// What a block's output wire shows online: its channel's value from the live
// stream (an input, a set-point, or the output block it feeds), else the
// block's own output from the task's watch (GET /api/watch).
function liveKey(b) {
  if (!ed.online || !b.id) return null;
  if (ed.view !== null) return ed.viewCall ? 'blk:' + ed.viewCall + '.' + b.id : null;
  const l = wireLabel(b);
  return l ? 'ch:' + l : 'blk:' + b.id;
}
function liveValue(key) {
  if (!ed.online) return null;
  return key.startsWith('ch:') ? ed.online.values.get(key.slice(3)) : ed.online.blocks.get(key.slice(4));
}
function refreshLive() {
  for (const t of $('ed-sheet').querySelectorAll('text.live')) {
    const x = liveValue(t.dataset.key);
    if (!x) continue;
    t.textContent = fmt(x.value) + ' ' + (x.forced ? 'FORCED' : x.quality);
    t.setAttribute('class', 'live q-' + x.quality);
  }
}

// Polls the task's watch while the editor is online on an FBD program: the
// runtime copies every block output about ten times a second while asked.
async function pollWatch() {
  const on = ed.online;
  if (!on || ed.readonly) return;
  const r = await call('GET', '/api/watch?task=' + encodeURIComponent(on.task));
  if (ed.online !== on) return;
  if (r.status === 200 && !r.data.result.pending) {
    on.blocks = new Map(r.data.result.blocks.map((b) => [b.name, b]));
    on.watchProgram = r.data.result.program;
    refreshLive();
  }
  on.timer = setTimeout(pollWatch, 300);
}

// Draws the current sheet into `svg` (the page's sheet, or a print page).
function drawSheet(svg, interactive) {
  const d = ed.diagram, bs = cur(), fs = formals();
  let cols = d.grid.cols, rows = d.grid.rows;
  for (const b of bs) { cols = Math.max(cols, b.col + 2); rows = Math.max(rows, b.row + 2); }
  cols = Math.max(cols, fs.length);
  if (interactive) { cols = Math.max(cols, ed.cursor.col + 1); rows = Math.max(rows, ed.cursor.row + 1); }
  svg.setAttribute('viewBox', '0 0 ' + cols * CW + ' ' + rows * CH);
  svg.setAttribute('width', cols * CW);
  svg.setAttribute('height', rows * CH);
  svg.replaceChildren();
  const errs = new Map();
  for (const x of (ed.verdict ? ed.verdict.diagnostics : [])) {
    if ((x.macro || null) !== ed.view || x.block === null || x.block === undefined) continue;
    if (!errs.has(x.block)) errs.set(x.block, []);
    errs.get(x.block).push(x);
  }
  for (let r = 0; r < rows; ++r) {
    for (let c = 0; c < cols; ++c) {
      const cell = edEl('rect', { x: c * CW, y: r * CH, width: CW, height: CH, class: 'cell' + (c >= d.grid.cols || r >= d.grid.rows ? ' past' : '') });
      if (interactive) {
        cell.addEventListener('click', (e) => {
          ed.cursor = { col: c, row: r };
          if (!place(c, r)) { if (!e.shiftKey) clearSelection(); draw(); showProps(); showView(); }
        });
      }
      svg.appendChild(cell);
    }
  }
  const byId = new Map();
  bs.forEach((b, i) => { if (b.id && !byId.has(b.id)) byId.set(b.id, i); });
  // Wires first, under the blocks; a one-cycle feedback reference dashed.
  bs.forEach((b, i) => {
    for (const p of inPins(b)) {
      const a = b.args[p.k];
      let o, feedback = false, src = null;
      if (a.ref && byId.has(a.ref)) { const j = byId.get(a.ref); src = bs[j]; o = outPin(src); feedback = j >= i; }
      else if (a.ref && fs.includes(a.ref)) o = formalPin(fs.indexOf(a.ref));
      else continue;
      let path;
      if (!src || src.row < b.row) {
        const my = (o.y + p.y) / 2;
        path = 'M' + o.x + ' ' + o.y + ' C' + o.x + ' ' + my + ' ' + p.x + ' ' + my + ' ' + p.x + ' ' + p.y;
      } else {
        const side = Math.max(blockBox(src).x + blockBox(src).w, blockBox(b).x + blockBox(b).w) + 12;
        path = 'M' + o.x + ' ' + o.y + ' v10 H' + side + ' V' + (p.y - 10) + ' H' + p.x + ' V' + p.y;
      }
      svg.appendChild(edEl('path', { d: path, class: 'wire' + (feedback ? ' fb' : ''), 'data-testid': 'wire-' + a.ref + '-' + i + '-' + p.k }));
    }
  });
  fs.forEach((f, k) => {
    const box = formalBox(k);
    const g = edEl('g', { class: 'formal', 'data-testid': 'formal-' + f });
    g.appendChild(edEl('rect', { x: box.x, y: box.y, width: box.w, height: box.h, rx: 10 }));
    g.appendChild(edEl('text', { x: box.x + box.w / 2, y: box.y + 15, class: 'kind', 'text-anchor': 'middle' }, f));
    const o = formalPin(k);
    const pin = edEl('circle', { cx: o.x, cy: o.y, r: 5, class: 'pin out', 'data-testid': 'out-' + f });
    if (interactive) pin.addEventListener('mousedown', (e) => { e.stopPropagation(); ed.drag = { kind: 'wire', ref: f }; });
    g.appendChild(pin);
    svg.appendChild(g);
  });
  bs.forEach((b, i) => {
    const box = blockBox(b);
    const s = !b.macro && ed.registry.get(b.kind);
    const g = edEl('g', { class: 'blk g-' + (b.macro ? 'macro' : s ? s.group : 'unknown') + (errs.has(i) ? ' err' : '') + (ed.sel.has(i) ? ' sel' : '') + (ed.connectFrom === i ? ' from' : ''), 'data-testid': 'block-' + (b.id || 'out-' + i) });
    g.appendChild(edEl('rect', { x: box.x, y: box.y, width: box.w, height: box.h, rx: 4 }));
    g.appendChild(edEl('text', { x: box.x + 6, y: box.y + 16, class: 'kind' }, b.kind));
    if (b.id) g.appendChild(edEl('text', { x: box.x + box.w - 6, y: box.y + 16, class: 'fno' }, b.id));
    const label = b.args.find((a) => 'string' in a);
    const params = b.args.filter((a) => 'number' in a || ('ref' in a && /^P/.test(a.ref))).map((a) => ('number' in a ? fmt(a.number) : a.ref)).join(', ');
    g.appendChild(edEl('text', { x: box.x + 6, y: box.y + 34, class: 'sub' }, label ? label.string : (b.macro ? 'macro ' : '') + params));
    const dev = b.args.filter((a) => 'device' in a).map((a) => a.device).join('.');
    if (dev) g.appendChild(edEl('text', { x: box.x + 6, y: box.y + 46, class: 'dev' }, dev));
    // Execution order: the F-number names the block, its place in the list runs it.
    g.appendChild(edEl('text', { x: box.x + box.w - 6, y: box.y + 46, class: 'ord' }, '#' + (i + 1)));
    if (errs.has(i)) g.appendChild(edEl('title', {}, errs.get(i).map((x) => x.message).join('\n')));
    if (interactive) {
      g.addEventListener('mousedown', (e) => { if (e.button === 0) ed.drag = { kind: 'move', i }; });
      g.addEventListener('click', (e) => {
        e.stopPropagation();
        if (e.shiftKey) {
          if (ed.sel.has(i)) ed.sel.delete(i); else ed.sel.add(i);
          ed.selected = ed.sel.has(i) ? i : null;
        } else selectOnly(i);
        ed.cursor = { col: b.col, row: b.row }; draw(); showProps(); showView();
      });
      g.addEventListener('dblclick', () => { if (b.macro) openMacro(b.kind, b.id); });
    }
    for (const p of inPins(b)) {
      const bad = (errs.get(i) || []).some((x) => x.arg === p.k);
      const pin = edEl('circle', { cx: p.x, cy: p.y, r: 5, class: 'pin in' + (b.args[p.k].ref === null ? ' open' : '') + (bad ? ' bad' : ''), 'data-testid': 'pin-' + i + '-' + p.k });
      if (interactive) {
        pin.addEventListener('mouseup', () => {
          const dr = ed.drag;
          ed.drag = null;
          if (dr && dr.kind === 'wire') { if (dr.ref) connectRef(dr.ref, i, p.k); else connect(dr.from, i, p.k); }
        });
      }
      g.appendChild(pin);
    }
    if (b.id) {
      const o = outPin(b);
      const pin = edEl('circle', { cx: o.x, cy: o.y, r: 5, class: 'pin out', 'data-testid': 'out-' + b.id });
      if (interactive) pin.addEventListener('mousedown', (e) => { e.stopPropagation(); ed.drag = { kind: 'wire', from: i }; });
      g.appendChild(pin);
      const key = liveKey(b);
      if (key) {
        const v = liveValue(key);
        g.appendChild(edEl('text', {
          x: o.x + 8, y: o.y + 14, class: 'live q-' + (v ? v.quality : 'none'), 'data-testid': 'live-' + b.id,
          'data-key': key,
        }, v ? fmt(v.value) + ' ' + (v.forced ? 'FORCED' : v.quality) : '…'));
      }
    }
    svg.appendChild(g);
  });
  if (interactive) {
    const c = ed.cursor;
    svg.appendChild(edEl('rect', { x: c.col * CW + 2, y: c.row * CH + 2, width: CW - 4, height: CH - 4, class: 'cursor', 'data-testid': 'cursor' }));
  }
  return { cols, rows };
}

function draw() {
  const svg = $('ed-sheet');
  if (!svg || !ed.diagram) return;
  drawSheet(svg, true);
  const bs = cur(), c = ed.cursor;
  $('ed-status').textContent = bs.length + ' blocks; cursor ' + c.col + ',' + c.row +
    (ed.sel.size > 1 ? '; ' + ed.sel.size + ' selected (Shift+arrows move them)' : '') +
    (ed.armed ? '; Enter places ' + ed.armed.name : '') + (ed.connectFrom !== null && bs[ed.connectFrom] ? '; Ins on a block connects ' + bs[ed.connectFrom].id : '');
}

function sheetCell(e) {
  const svg = $('ed-sheet');
  const r = svg.getBoundingClientRect();
  const vb = svg.viewBox.baseVal;
  return { col: Math.floor(((e.clientX - r.left) * vb.width / r.width) / CW), row: Math.floor(((e.clientY - r.top) * vb.height / r.height) / CH) };
}

// Moves the selected blocks by (dc, dr) when every target cell is free.
function moveSelection(dc, dr) {
  const bs = cur();
  const idx = ed.sel.size ? [...ed.sel] : (ed.selected !== null ? [ed.selected] : []);
  if (!idx.length) return false;
  const moving = new Set(idx);
  for (const i of idx) {
    const c = bs[i].col + dc, r = bs[i].row + dr;
    if (c < 0 || r < 0) return false;
    const other = blockAt(c, r);
    if (other >= 0 && !moving.has(other)) return false;
  }
  change(() => { for (const i of idx) { bs[i].col += dc; bs[i].row += dr; } ed.cursor = { col: ed.cursor.col + dc, row: ed.cursor.row + dr }; });
  return true;
}

// ---- the selected block's properties ----------------------------------------
function showProps() {
  const box = $('ed-props');
  // A field that had the keys keeps them when the panel is drawn again.
  // (By place: an optional parameter's field becomes the written parameter's.)
  const fields = () => [...box.querySelectorAll('input, select, button')];
  const had = box.contains(document.activeElement) ? fields().indexOf(document.activeElement) : -1;
  renderProps(box);
  if (had >= 0) { const f = fields()[had]; if (f) f.focus(); else $('ed-sheet').focus(); }
}

function renderProps(box) {
  box.replaceChildren();
  if (ed.selected === null || !cur()[ed.selected]) { box.appendChild(el('p', 'no block selected', 'muted')); return; }
  const i = ed.selected, b = cur()[i];
  const s = !b.macro && ed.registry.get(b.kind);
  box.appendChild(el('h4', (b.macro ? 'MACRO ' : '') + b.kind + (b.id ? ' — ' + b.id : '')));
  if (b.id) {
    // The F-number names the block (the seed writes it); renaming keeps every wire.
    const l = el('label', 'name ');
    const f = el('input');
    f.value = b.id;
    f.dataset.testid = 'prop-id';
    const said = el('span', '', 'error');
    f.addEventListener('change', () => { const err = renameBlock(i, f.value.trim()); if (err) { said.textContent = err; f.value = b.id; } });
    l.appendChild(f);
    box.appendChild(l);
    box.appendChild(said);
  }
  box.appendChild(el('p', 'runs ' + (i + 1) + ' of ' + cur().length, 'muted'));
  const ids = [...formals(), ...cur().filter((x) => x.id).map((x) => x.id)];
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
  // Optional parameters not written yet: a value typed here writes it (and
  // those before it, at their defaults).
  const refs = b.args.filter((a) => isValueRef(a)).length;
  if (s && s.signature === 'compute' && refs === s.inputs.length) {
    s.params.slice(param).forEach((p, j) => {
      const field = el('input');
      field.inputMode = 'decimal';
      field.placeholder = 'default ' + (p.default ?? '');
      field.title = p.meaning + (p.min !== null || p.max !== null ? ' [' + (p.min ?? '') + ', ' + (p.max ?? '') + ']' : '');
      field.dataset.testid = 'prop-opt-' + (param + j);
      field.addEventListener('change', () => {
        const v = field.value.trim();
        if (v === '' || !Number.isFinite(Number(v))) { field.value = ''; return; }
        change(() => { for (let q = param; q <= param + j; ++q) b.args.push({ number: q === param + j ? Number(v) : (s.params[q].default ?? 0) }); });
      });
      const l = el('label', p.name + ' ');
      l.appendChild(field);
      box.appendChild(l);
    });
  }
  if (b.macro && macroOf(b.kind)) {
    for (const [text, id, fn] of [['open macro', 'prop-open-macro', () => openMacro(b.kind, b.id)], ['expand', 'prop-expand', () => expandMacro(i)]]) {
      const x = el('button', text);
      x.type = 'button';
      x.dataset.testid = id;
      x.addEventListener('click', fn);
      box.appendChild(x);
      box.appendChild(document.createTextNode(' '));
    }
  }
  const del = el('button', 'delete block');
  del.type = 'button';
  del.dataset.testid = 'prop-delete';
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
  showReadOnly(false);
  ed.diagram = r.data.diagram;
  ed.history = []; ed.future = []; clearSelection(); ed.view = null; ed.cursor = { col: 0, row: 0 };
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
  if (/\.(sfc|xml)$/.test(name)) { await openView(r.data.text, name); return; }
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

// ---- SFC charts and PLCopen projects, read-only ------------------------------
// A file the editor does not edit opens as a picture of itself: an SFC chart
// as the console's Chart page draws it (its steps lit while a running task's
// is shown online), a PLCopen project's POUs with their elements where the
// project puts them (laid out by flow when it puts them all at one point).
function showReadOnly(on) {
  $('ed-wrap').hidden = on;
  $('ed-readonly').hidden = !on;
  if (!on) { ed.readonly = null; $('ed-readonly').replaceChildren(); }
}

async function openView(text, name) {
  const r = await call('POST', '/api/view', { text, file: name });
  const v = $('ed-verdict');
  if (r.status !== 200) { v.className = 'error'; v.textContent = (r.data.error && r.data.error.message) || 'HTTP ' + r.status; return false; }
  const box = $('ed-readonly');
  box.replaceChildren();
  ed.readonly = { kind: r.data.kind, name, steps: new Map() };
  clearSelection();
  showProps();
  $('ed-macro-form').hidden = true;
  $('ed-name').value = name;
  showReadOnly(true);
  v.className = '';
  v.dataset.identity = '';
  if (r.data.kind === 'sfc') {
    const c = r.data;
    v.textContent = name + ': SFC chart ' + c.chart + ', ' + c.steps.length + ' steps, ' + c.transitions.length + ' transitions (read-only)';
    box.appendChild(chartSvg(c, ed.readonly.steps));
  } else {
    v.textContent = name + ': PLCopen project, ' + r.data.pous.length + ' POUs (read-only)';
    for (const p of r.data.pous) box.appendChild(pouView(p));
  }
  $('ed-view').textContent = 'read-only: ' + name;
  if (typeof resubscribe === 'function') resubscribe();
  return true;
}

function pouView(p) {
  const sec = el('div', '', 'pou');
  sec.dataset.testid = 'pou-' + p.name;
  sec.appendChild(el('h4', p.type + ' ' + p.name + ' (' + p.language + ')'));
  if (!p.elements.length) {
    if (p.source) sec.appendChild(el('pre', p.source));
    return sec;
  }
  // Where each element goes: the project's position, or its flow depth.
  const perDepth = new Map();
  const pos = new Map();
  for (const e of p.elements) {
    const w = Math.max(e.w || 0, 90), h = Math.max(e.h || 0, 34);
    if (p.positioned) pos.set(e.id, { x: e.x, y: e.y, w, h });
    else {
      const k = perDepth.get(e.depth) || 0;
      perDepth.set(e.depth, k + 1);
      pos.set(e.id, { x: e.depth * 170, y: k * 70, w, h });
    }
  }
  let W = 0, H = 0;
  for (const b of pos.values()) { W = Math.max(W, b.x + b.w + 20); H = Math.max(H, b.y + b.h + 20); }
  const svg = edEl('svg', { viewBox: '-10 -10 ' + (W + 20) + ' ' + (H + 20), width: W + 20, class: 'pou-sheet' });
  for (const e of p.elements) {
    const b = pos.get(e.id);
    e.inputs.forEach((inp, k) => {
      const s = pos.get(inp.from);
      if (!s) return;
      const y2 = b.y + (k + 1) * b.h / (e.inputs.length + 1);
      svg.appendChild(edEl('path', { d: 'M' + (s.x + s.w) + ' ' + (s.y + s.h / 2) + ' C' + (s.x + s.w + 30) + ' ' + (s.y + s.h / 2) + ' ' + (b.x - 30) + ' ' + y2 + ' ' + b.x + ' ' + y2, class: 'wire' }));
      if (inp.pin) svg.appendChild(edEl('text', { x: b.x + 3, y: y2 + 4, class: 'pin-name' }, (inp.negated ? '¬' : '') + inp.pin));
    });
  }
  for (const e of p.elements) {
    const b = pos.get(e.id);
    const g = edEl('g', { class: 'el el-' + e.element, 'data-testid': 'el-' + p.name + '-' + e.id });
    g.appendChild(edEl('rect', { x: b.x, y: b.y, width: b.w, height: b.h, rx: e.element === 'block' ? 3 : 12 }));
    g.appendChild(edEl('text', { x: b.x + b.w / 2, y: b.y - 3, class: 'inst', 'text-anchor': 'middle' }, e.instance || ''));
    g.appendChild(edEl('text', { x: b.x + b.w / 2, y: b.y + (e.element === 'block' ? 14 : b.h / 2 + 4), class: 'lbl', 'text-anchor': 'middle' }, e.label || e.element));
    svg.appendChild(g);
  }
  sec.appendChild(svg);
  if (!p.positioned) sec.appendChild(el('p', 'the project puts its elements at one point: laid out here by flow, left to right', 'muted'));
  return sec;
}

// ---- keys: the seed's block cursor ----------------------------------------
function editorKey(e) {
  const bs = cur(), c = ed.cursor;
  const at = blockAt(c.col, c.row);
  const ctrl = e.ctrlKey || e.metaKey;
  const arrows = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1] };
  if (ctrl && e.key === 'z') { undo(); }
  else if (ctrl && (e.key === 'y' || e.key === 'Z')) { redo(); }
  else if (ctrl && e.key === 'c') { if (at >= 0) ed.clipboard = JSON.parse(JSON.stringify(bs[at])); }
  else if (ctrl && e.key === 'v') {
    if (ed.clipboard && at < 0) {
      const b = JSON.parse(JSON.stringify(ed.clipboard));
      b.col = c.col; b.row = c.row;
      if (b.id) b.id = nextId(b.id[0]);
      change(() => { bs.push(b); selectOnly(bs.length - 1); });
    }
  } else if (e.shiftKey && arrows[e.key]) { moveSelection(...arrows[e.key]); }
  else if (arrows[e.key]) {
    c.col = Math.max(0, c.col + arrows[e.key][0]);
    c.row = Math.max(0, c.row + arrows[e.key][1]);
  } else if (e.key === 'Enter') {
    if (at >= 0) { selectOnly(at); showProps(); } else place(c.col, c.row);
  } else if (e.key === ' ') {
    // Space: the block under the cursor in or out of the selection.
    if (at < 0) return e.preventDefault();
    if (ed.sel.has(at)) ed.sel.delete(at); else ed.sel.add(at);
    ed.selected = ed.sel.has(at) ? at : null;
    showProps(); showView();
  } else if (e.key === 'Insert' || e.key === 'i') {
    if (at < 0) {
      // Inside a macro, Ins on a formal's cell (the top row) starts from it.
      const fs = formals();
      if (ed.view !== null && c.row === 0 && c.col < fs.length) ed.connectFrom = { ref: fs[c.col] };
      else return;
    } else if (ed.connectFrom === null) { if (bs[at].id) ed.connectFrom = at; }
    else {
      const from = ed.connectFrom;
      ed.connectFrom = null;
      if (typeof from === 'object') connectRef(from.ref, at); else connect(from, at);
    }
  } else if (e.key === 'Delete') { if (at >= 0) removeBlock(at); }
  else if (e.key === 'Escape') { ed.armed = null; ed.connectFrom = null; clearSelection(); buildPalette(); showProps(); showView(); }
  else if (e.key === '/') { $('ed-search').focus(); $('ed-search').select(); }
  else if (e.key === 'p') { const f = $('ed-props').querySelector('input, select'); if (f) f.focus(); }
  else if (e.key === 'm') { showMacroForm(); }
  else if (e.key === 'o') { if (at >= 0 && bs[at].macro) openMacro(bs[at].kind, bs[at].id); }
  else if (e.key === 'Backspace') { if (ed.view !== null) closeMacro(); }
  else return;
  e.preventDefault();
  draw();
  // Keep the cursor in view: the sheet scrolls past one screen, as the seed's does.
  const wrap = $('ed-wrap');
  const x = c.col * CW, y = c.row * CH;
  if (x < wrap.scrollLeft || x + CW > wrap.scrollLeft + wrap.clientWidth) wrap.scrollLeft = x - CW;
  if (y < wrap.scrollTop || y + CH > wrap.scrollTop + wrap.clientHeight) wrap.scrollTop = y - CH;
}
// ---- simulation: the diagram against a plant model of rtplc sim --------------
// Steps are written as rtplc sim takes them: LABEL=VALUE@SECONDS, comma-separated.
function parseSteps(text) {
  const out = [];
  for (const part of text.split(',').map((x) => x.trim()).filter(Boolean)) {
    const m = /^([^=@\s]+)=([^@]+)@(.+)$/.exec(part);
    if (!m || !Number.isFinite(Number(m[2])) || !Number.isFinite(Number(m[3]))) throw new Error('a step is LABEL=VALUE@SECONDS, e.g. Setpoint=60@20, not "' + part + '"');
    out.push({ label: m[1], value: Number(m[2]), at: Number(m[3]) });
  }
  return out;
}

async function simulate() {
  const said = $('ed-sim-said');
  let steps;
  try { steps = parseSteps($('ed-sim-steps').value); } catch (e) { said.className = 'error'; said.textContent = e.message; return; }
  said.className = '';
  said.textContent = 'simulating…';
  $('ed-sim-figures').textContent = '';
  ed.sim = null;
  const simulation = { plant: $('ed-sim-plant').value.trim(), duration: Number($('ed-sim-duration').value), steps };
  const r = await call('POST', '/api/fbd/simulate', { diagram: written(), file: $('ed-name').value, simulation });
  if (r.status !== 200) { said.className = 'error'; said.textContent = (r.data.error && r.data.error.message) || 'HTTP ' + r.status; return; }
  if (!r.data.compiles) { said.className = 'error'; said.textContent = 'does not compile:\n' + r.data.rendered; return; }
  ed.sim = r.data;
  said.textContent = r.data.cycles + ' cycles of ' + r.data.period_s + ' s, plant ' + r.data.plant +
    (r.data.block_errors ? ', ' + r.data.block_errors + ' block errors (outputs held)' : '') +
    (r.data.diverged_at !== null ? ' — UNSTABLE: the measurement diverged at ' + r.data.diverged_at + ' s' : '');
  $('ed-sim-figures').textContent = r.data.figures;
  $('ed-sim-csv').hidden = false;
  plotSim(0);
}

// The plot, drawn as the rows come in: measurement and set-points on top,
// outputs below, the same split as rtplc sim --plot.
function plotSim(upTo) {
  const s = ed.sim, svg = $('ed-sim-plot');
  if (!s) return;
  const W = 760, H = 300, L = 50, R = 10, top = [10, 150], ph = 120;
  const rows = s.rows, n = rows.length;
  const end = Math.min(n, upTo + Math.max(1, Math.ceil(n / 30)));
  const t0 = rows[0][0], t1 = rows[n - 1][0] || 1;
  const X = (t) => L + (W - L - R) * (t - t0) / ((t1 - t0) || 1);
  svg.setAttribute('viewBox', '0 0 ' + W + ' ' + H);
  svg.replaceChildren();
  const panes = [[], []];
  s.columns.forEach((name, k) => { if (k > 0) panes[s.is_output[k] ? 1 : 0].push(k); });
  const colors = ['#1f5fbf', '#d11', '#2a8a3a', '#a85f00', '#7a3fb0', '#555'];
  panes.forEach((cols, p) => {
    if (!cols.length) return;
    let lo = Infinity, hi = -Infinity;
    for (const r of rows) for (const k of cols) { lo = Math.min(lo, r[k]); hi = Math.max(hi, r[k]); }
    if (lo === hi) { lo -= 1; hi += 1; }
    const Y = (v) => top[p] + ph - ph * (v - lo) / (hi - lo);
    svg.appendChild(edEl('rect', { x: L, y: top[p], width: W - L - R, height: ph, class: 'pane' }));
    svg.appendChild(edEl('text', { x: L - 4, y: top[p] + 10, class: 'ax' }, fmt(hi)));
    svg.appendChild(edEl('text', { x: L - 4, y: top[p] + ph, class: 'ax' }, fmt(lo)));
    cols.forEach((k, j) => {
      let d = '';
      for (let i = 0; i < end; ++i) d += (i ? 'L' : 'M') + X(rows[i][0]).toFixed(1) + ' ' + Y(rows[i][k]).toFixed(1);
      svg.appendChild(edEl('path', { d, class: 'sig', stroke: colors[(p * 3 + j) % colors.length], 'data-testid': 'sim-line-' + s.columns[k] }));
      svg.appendChild(edEl('text', { x: L + 6 + j * 110, y: top[p] + 12, fill: colors[(p * 3 + j) % colors.length], class: 'leg' }, s.columns[k]));
    });
  });
  svg.appendChild(edEl('text', { x: L, y: H - 4, class: 'ax0' }, fmt(t0) + ' s'));
  svg.appendChild(edEl('text', { x: W - R, y: H - 4, class: 'ax' }, fmt(t1) + ' s'));
  svg.dataset.points = String(end);
  if (end < n) requestAnimationFrame(() => plotSim(end));
}

function downloadText(body, name, type) {
  const a = document.createElement('a');
  a.href = URL.createObjectURL(new Blob([body], { type }));
  a.download = name;
  a.click();
  URL.revokeObjectURL(a.href);
}

// ---- print: the diagram as SVG, and as pages with a title block ------------
function titleBlock() {
  const v = ed.verdict;
  return [
    ['file', ($('ed-name').value || 'untitled.fbd') + (ed.view !== null ? ' — macro ' + ed.view : '')],
    ['program', v && v.compiles ? v.program_hash + ' (identity ' + v.identity + ')' : 'does not compile'],
    ['period', ed.diagram.period_s === null ? 'default' : ed.diagram.period_s + ' s'],
    ['date', new Date().toISOString().slice(0, 16).replace('T', ' ') + ' UTC'],
    ['blocks', String(cur().length)],
  ];
}

// The styles the sheet needs, for an SVG that stands alone.
function sheetStyles() {
  let css = '';
  for (const sheet of document.styleSheets) {
    let rules;
    try { rules = sheet.cssRules; } catch (e) { continue; }
    for (const r of rules) if (r.selectorText && r.selectorText.includes('.sheet')) css += r.cssText.replace(/\.sheet\b/g, 'svg') + '\n';
  }
  return css;
}

function downloadSvg() {
  const svg = edEl('svg', { xmlns: 'http://www.w3.org/2000/svg', class: 'sheet' });
  const size = drawSheet(svg, false);
  const w = size.cols * CW, h = size.rows * CH, tb = 22 * titleBlock().length + 10;
  const out = edEl('svg', { xmlns: 'http://www.w3.org/2000/svg', width: w, height: h + tb, viewBox: '0 0 ' + w + ' ' + (h + tb) });
  out.appendChild(edEl('style', {}, sheetStyles()));
  svg.setAttribute('y', 0);
  out.appendChild(svg);
  titleBlock().forEach(([k, v], j) => out.appendChild(edEl('text', { x: 8, y: h + 20 + 22 * j, style: 'font: 13px sans-serif' }, k + ': ' + v)));
  downloadText(new XMLSerializer().serializeToString(out), ($('ed-name').value || 'untitled.fbd').replace(/\.fbd$/, '') + '.svg', 'image/svg+xml');
}

// Pages for the print stylesheet: the sheet cut into bands of whole grid
// cells that fit the paper (A4 or Letter, landscape), each page with the title
// block; a sheet wider than the paper is scaled down to 60 %, then cut across too.
function buildPrint() {
  const paper = $('ed-paper').value;
  const mm = paper === 'letter' ? [279.4, 215.9] : [297, 210];
  const px = (v) => v * 96 / 25.4;
  const areaW = px(mm[0] - 20), areaH = px(mm[1] - 20) - 120;
  const full = edEl('svg', { class: 'sheet' });
  const size = drawSheet(full, false);
  const scale = Math.max(0.6, Math.min(1, areaW / (size.cols * CW)));
  const perRow = Math.max(1, Math.floor(areaW / (CW * scale))), perCol = Math.max(1, Math.floor(areaH / (CH * scale)));
  const box = $('ed-print');
  box.replaceChildren();
  const style = document.getElementById('ed-page-style') || document.head.appendChild(Object.assign(document.createElement('style'), { id: 'ed-page-style' }));
  style.textContent = '@page { size: ' + (paper === 'letter' ? 'letter' : 'A4') + ' landscape; margin: 10mm; }';
  const pages = [];
  for (let r0 = 0; r0 < size.rows; r0 += perCol) for (let c0 = 0; c0 < size.cols; c0 += perRow) pages.push([c0, r0]);
  pages.forEach(([c0, r0], p) => {
    const page = el('div', '', 'print-page');
    page.dataset.testid = 'print-page';
    const tb = el('table', '', 'title-block');
    for (const [k, v] of [...titleBlock(), ['page', (p + 1) + ' of ' + pages.length + ' (columns ' + c0 + '–' + Math.min(size.cols, c0 + perRow) + ', rows ' + r0 + '–' + Math.min(size.rows, r0 + perCol) + ')']]) {
      const tr = el('tr');
      tr.appendChild(el('th', k));
      tr.appendChild(el('td', v));
      tb.appendChild(tr);
    }
    const w = Math.min(perRow, size.cols - c0) * CW, h = Math.min(perCol, size.rows - r0) * CH;
    const svg = full.cloneNode(true);
    svg.setAttribute('viewBox', c0 * CW + ' ' + r0 * CH + ' ' + w + ' ' + h);
    svg.setAttribute('width', Math.round(w * scale));
    svg.setAttribute('height', Math.round(h * scale));
    page.appendChild(svg);
    page.appendChild(tb);
    box.appendChild(page);
  });
  return pages.length;
}

function printDiagram() { buildPrint(); window.print(); }

// ---- online: a running task's program, live, swapped from here --------------
async function loadTasks() {
  const r = await call('GET', '/api/status');
  const sel = $('ed-task');
  const was = sel.value;
  sel.replaceChildren();
  if (r.status !== 200) return;
  const tasks = (r.data.result && r.data.result.status && r.data.result.status.tasks) || [];
  for (const t of tasks) { const o = el('option', t.name); o.value = t.name; sel.appendChild(o); }
  if (was) sel.value = was;
}

async function openRunning() {
  const task = $('ed-task').value;
  if (!task) return;
  opening('task ' + task);
  const r = await call('GET', '/api/program?task=' + encodeURIComponent(task));
  if (r.status !== 200) { $('ed-verdict').textContent = r.data.error.message; return; }
  const res = r.data.result;
  if (ed.online) clearTimeout(ed.online.timer);
  ed.online = { task, running: res.running, values: new Map(), blocks: new Map(), timer: 0 };
  const fbd = await call('POST', '/api/fbd/to-diagram', { text: res.source, layout: null, file: task + '.fbd' });
  if (fbd.status === 200) await openText(res.source, null, task + '.fbd');
  else if (!(await openView(res.source, task + (res.source.trimStart().startsWith('<') ? '.xml' : '.sfc')))) { ed.online = null; return; }
  $('ed-online-said').textContent = 'online: task ' + task + ', program ' + res.running + ' (' + (res.origin || '') + '); every wire shows its value and status live';
  if (typeof resubscribe === 'function') resubscribe();
  draw();
  pollWatch();
}

// The labels whose values this page shows: what the live stream should carry.
function editorLiveLabels() {
  if (ed.online && ed.readonly) return [...ed.readonly.steps.keys()];
  if (!ed.online || ed.view !== null) return [];
  const out = new Set();
  for (const b of ed.diagram.blocks) { const l = wireLabel(b); if (l) out.add(l); }
  return [...out];
}
function editorLiveValue(v) {
  if (!ed.online) return;
  if (ed.readonly) { const g = ed.readonly.steps.get(v.label); if (g) g.classList.toggle('active', v.value !== 0); return; }
  ed.online.values.set(v.label, v);
  clearTimeout(ed.liveTimer);
  ed.liveTimer = setTimeout(refreshLive, 50);
}

async function swapCheck() {
  const said = $('ed-online-said');
  const task = $('ed-task').value;
  ed.pendingSwap = null;
  $('ed-swap-confirm').hidden = true;
  const t = await call('POST', '/api/fbd/to-text', { diagram: written() });
  if (t.status !== 200) { said.textContent = t.data.error.message; return; }
  const upload = { task, name: $('ed-name').value || task + '.fbd', source: t.data.text };
  const r = await call('POST', '/api/swap/check', upload);
  const report = $('ed-swap-report');
  report.hidden = false;
  report.textContent = r.data.ok ? r.data.result.text : (r.data.error && r.data.error.message) || 'HTTP ' + r.status;
  if (r.data.ok) {
    ed.pendingSwap = upload;
    $('ed-swap-confirm').hidden = false;
    said.textContent = 'the compiler accepts it: read what is kept and reset, then confirm';
  } else said.textContent = 'refused: nothing changed';
}

async function swapConfirm() {
  const upload = ed.pendingSwap;
  ed.pendingSwap = null;
  $('ed-swap-confirm').hidden = true;
  if (!upload) return;
  const r = await call('POST', '/api/swap', upload);
  $('ed-online-said').textContent = r.data.ok ? 'swapped: task ' + upload.task + ' runs the edited program' : 'refused: ' + ((r.data.error && r.data.error.message) || 'HTTP ' + r.status);
  $('ed-swap-report').textContent = r.data.ok ? r.data.result.text : ((r.data.error && r.data.error.message) || '');
}

async function rollbackTask() {
  const task = $('ed-task').value;
  if (!task || !window.confirm('Roll task ' + task + ' back to its previous program?')) return;
  const r = await call('POST', '/api/rollback', { task });
  $('ed-online-said').textContent = r.data.ok ? 'rolled back: task ' + task + ' runs its previous program (open running to see it)' : 'refused: ' + ((r.data.error && r.data.error.message) || 'HTTP ' + r.status);
}

function goOffline() { if (ed.online) clearTimeout(ed.online.timer); ed.online = null; $('ed-online-said').textContent = 'offline'; if (typeof resubscribe === 'function') resubscribe(); draw(); }

function editorWire() {
  const svg = $('ed-sheet');
  svg.addEventListener('keydown', editorKey);
  svg.addEventListener('mouseup', (e) => {
    const drag = ed.drag;
    ed.drag = null;
    if (!drag || drag.kind !== 'move') return;
    const to = sheetCell(e), b = cur()[drag.i];
    if (!b || (to.col === b.col && to.row === b.row)) return;
    // A block of the selection drags the selection with it.
    if (ed.sel.has(drag.i) && ed.sel.size > 1) { moveSelection(to.col - b.col, to.row - b.row); return; }
    if (blockAt(to.col, to.row) >= 0) return;
    change(() => { b.col = to.col; b.row = to.row; ed.cursor = to; });
  });
  $('ed-search').addEventListener('input', buildPalette);
  // Enter in the search arms the first block it leaves and goes back to the sheet.
  $('ed-search').addEventListener('keydown', (e) => {
    if (e.key !== 'Enter' && e.key !== 'Escape') return;
    e.preventDefault();
    const q = $('ed-search').value.trim();
    const first = $('ed-palette').querySelector('[data-testid="palette-' + CSS.escape(q) + '"]') || $('ed-palette').querySelector('button.pal');
    if (e.key === 'Enter' && first && !first.classList.contains('armed')) first.click();
    $('ed-sheet').focus();
  });
  // In the properties, Escape goes back to the sheet (Enter applies the field).
  $('ed-props').addEventListener('keydown', (e) => {
    if (e.key === 'Escape') { e.preventDefault(); $('ed-sheet').focus(); }
  });
  $('ed-new').addEventListener('click', () => newDiagram(Math.max(1, Number($('ed-cols').value) || 7), Math.max(1, Number($('ed-rows').value) || 5)));
  $('ed-open').addEventListener('click', openFromWorkspace);
  $('ed-upload').addEventListener('change', async () => {
    const f = $('ed-upload').files[0];
    if (!f) return;
    opening(f.name);
    if (/\.(sfc|xml)$/.test(f.name)) await openView(await f.text(), f.name); else await openText(await f.text(), null, f.name);
  });
  $('ed-save').addEventListener('click', () => saveTo('workspace'));
  $('ed-download').addEventListener('click', () => saveTo('download'));
  $('ed-undo').addEventListener('click', undo);
  $('ed-redo').addEventListener('click', redo);
  $('ed-period').addEventListener('change', () => {
    const v = $('ed-period').value.trim();
    change(() => { ed.diagram.period_s = v === '' ? null : Number(v); });
  });
  $('ed-macro-new').addEventListener('click', showMacroForm);
  $('ed-sim-run').addEventListener('click', simulate);
  $('ed-sim-csv').addEventListener('click', () => { if (ed.sim) downloadText(ed.sim.csv, ($('ed-name').value || 'untitled.fbd').replace(/\.fbd$/, '') + '-sim.csv', 'text/csv'); });
  $('ed-print-btn').addEventListener('click', printDiagram);
  $('ed-svg').addEventListener('click', downloadSvg);
  window.addEventListener('beforeprint', () => { if (ed.diagram && !document.querySelector('#ed-print .print-page')) buildPrint(); });
  $('ed-task-refresh').addEventListener('click', loadTasks);
  $('ed-online').addEventListener('click', openRunning);
  $('ed-offline').addEventListener('click', goOffline);
  $('ed-swap-check').addEventListener('click', swapCheck);
  $('ed-swap-confirm').addEventListener('click', swapConfirm);
  $('ed-rollback').addEventListener('click', rollbackTask);
}
document.addEventListener('DOMContentLoaded', editorWire);
