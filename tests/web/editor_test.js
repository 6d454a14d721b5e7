// Drives the FBD editor page in Debian's chromium (headless) through
// playwright-core: an engineer logs in, opens the seed's PID loop from the
// workspace (drawn on the seed's grid, checked by the compiler), saves a copy
// that opens to the same program identity, draws an error and sees it on the
// block, undoes and redoes it, and builds a small loop with the mouse and
// again with the keyboard only (arrows, Enter, Ins) that compiles.
// Then: every example of the workspace opens and saves to the same program;
// the seed's PID loop is built from an empty page with the mouse and again
// with the keyboard only (its macro made from a selection), each compiling to
// the example's program; it is simulated (figures as rtplc sim prints them, the
// plot, the CSV), printed to PDF (checked with pdftotext and pdftoppm), and
// the running seed loop is opened online, its ProcVal seen changing on its
// wire, an edited gain swapped in after the migration report, the loop with
// it answering a set-point step on its wires, and rolled back.
// Usage: node editor_test.js BASE_URL USER PASSWORD SHOTS_DIR WORKSPACE RTPLC
'use strict';
const assert = require('assert');
const fs = require('fs');
const path = require('path');
const { chromium } = require('playwright-core');

const { execFileSync } = require('child_process');

const [base, user, password, shots, ws, rtplc] = process.argv.slice(2);

(async () => {
  fs.mkdirSync(shots, { recursive: true });
  const userDir = fs.mkdtempSync(path.join(require('os').tmpdir(), 'rtplc-chromium-'));
  const browser = await chromium.launchPersistentContext(userDir, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
      '--disable-component-update', '--disable-sync'],
    viewport: { width: 1400, height: 950 },
    bypassCSP: true,
  });
  const page = browser.pages()[0] || await browser.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  const verdict = () => page.textContent('[data-testid="ed-verdict"]');
  const compiles = () => page.waitForFunction(() => /^compiles — program identity [0-9a-f]{16}$/.test(
    document.querySelector('[data-testid="ed-verdict"]').textContent), null, { timeout: 15000 });
  const identity = () => page.getAttribute('[data-testid="ed-verdict"]', 'data-identity');
  try {
    await page.goto(base + '/');
    await page.fill('[data-testid="login-user"]', user);
    await page.fill('[data-testid="login-password"]', password);
    await page.click('[data-testid="login-submit"]');
    await page.waitForSelector('[data-testid="nav-editor"]');
    await page.click('[data-testid="nav-editor"]');
    await page.waitForSelector('[data-testid="palette-pid"]');
    await page.waitForFunction(() => document.querySelector('[data-testid="ed-workspace"]').textContent !== '');
    assert.match(await page.textContent('[data-testid="ed-workspace"]'), /^workspace /);

    // Open the seed's loop: four blocks on the grid, inputs above the macro above the output.
    await page.waitForFunction(() => [...document.querySelectorAll('[data-testid="ed-files"] option')].some((o) => o.value === 'seed_pid.fbd'));
    await page.selectOption('[data-testid="ed-files"]', 'seed_pid.fbd');
    await page.click('[data-testid="ed-open"]');
    await page.waitForSelector('[data-testid="block-F10"]');
    for (const id of ['F1', 'F2', 'F10']) await page.waitForSelector(`[data-testid="block-${id}"]`);
    await page.waitForSelector('[data-testid="wire-F10-3-0"]', { state: 'attached' });
    await compiles();
    const original = await identity();
    await page.screenshot({ path: path.join(shots, 'editor.png'), fullPage: true });

    // Save a copy; it opens to the same program.
    await page.fill('[data-testid="ed-name"]', 'seed_copy.fbd');
    await page.click('[data-testid="ed-save"]');
    await page.waitForFunction(() => /^saved seed_copy.fbd/.test(document.querySelector('[data-testid="ed-saved"]').textContent));
    assert.ok(fs.existsSync(path.join(ws, 'seed_copy.fbd.layout')), 'no layout sidecar was written');
    await page.waitForFunction(() => [...document.querySelectorAll('[data-testid="ed-files"] option')].some((o) => o.value === 'seed_copy.fbd'));
    await page.selectOption('[data-testid="ed-files"]', 'seed_copy.fbd');
    await page.click('[data-testid="ed-open"]');
    await page.waitForSelector('[data-testid="block-F10"]');
    await compiles();
    assert.strictEqual(await identity(), original, 'the saved copy is another program');

    // An error on a block: the output's channel out of range, drawn on the block
    // with the compiler's message; undo clears it, redo brings it back.
    await page.click('[data-testid="block-out-3"]');
    await page.fill('[data-testid="prop-3"]', 'c99999');
    await page.press('[data-testid="prop-3"]', 'Enter');
    await page.waitForSelector('[data-testid="block-out-3"].err');
    assert.match(await verdict(), /seed_copy\.fbd:\d+:\d+: error: c number 99999 is out of range/);
    await page.screenshot({ path: path.join(shots, 'editor-error.png'), fullPage: true });
    await page.click('[data-testid="ed-undo"]');
    await compiles();
    assert.strictEqual(await page.$('[data-testid="block-out-3"].err'), null);
    await page.click('[data-testid="ed-redo"]');
    await page.waitForSelector('[data-testid="block-out-3"].err');
    await page.click('[data-testid="ed-undo"]');
    await compiles();

    // With the mouse: a set-point, a filter and an output, wired by dragging.
    await page.click('[data-testid="ed-new"]');
    const cell = async (col, row) => {
      const box = await page.locator('[data-testid="ed-sheet"]').boundingBox();
      await page.mouse.click(box.x + col * 140 + 70, box.y + row * 86 + 43);
    };
    await page.click('[data-testid="palette-asp"]');
    await cell(1, 0);
    await page.click('[data-testid="palette-filt"]');
    await cell(1, 1);
    await page.click('[data-testid="palette-dao"]');
    await cell(1, 2);
    await page.click('[data-testid="palette-dao"]');  // disarm
    const drag = async (from, to) => {
      const a = await page.locator(`[data-testid="${from}"]`).boundingBox();
      const b = await page.locator(`[data-testid="${to}"]`).boundingBox();
      await page.mouse.move(a.x + a.width / 2, a.y + a.height / 2);
      await page.mouse.down();
      await page.mouse.move(b.x + b.width / 2, b.y + b.height / 2, { steps: 5 });
      await page.mouse.up();
    };
    await page.waitForFunction(() => /not connected/.test(document.querySelector('[data-testid="ed-verdict"]').textContent));
    await drag('out-F1', 'pin-1-0');
    await drag('out-F2', 'pin-2-0');
    await compiles();

    // With the keyboard only: the seed's cursor, Enter to place, Ins to connect.
    await page.click('[data-testid="ed-new"]');
    await page.focus('[data-testid="ed-sheet"]');
    const key = (k) => page.keyboard.press(k);
    await page.fill('[data-testid="ed-search"]', 'asp');
    await page.click('[data-testid="palette-asp"]');
    await page.focus('[data-testid="ed-sheet"]');
    await key('Enter');                       // asp at 0,0
    await page.fill('[data-testid="ed-search"]', 'dao');
    await page.click('[data-testid="palette-dao"]');
    await page.focus('[data-testid="ed-sheet"]');
    await key('ArrowDown');
    await key('ArrowDown');
    await key('Enter');                       // dao at 0,2
    await key('Escape');
    await key('ArrowUp');
    await key('ArrowUp');
    await key('Insert');                      // from the asp
    await key('ArrowDown');
    await key('ArrowDown');
    await key('Insert');                      // to the dao
    await compiles();
    await page.waitForSelector('[data-testid="wire-F1-1-0"]', { state: 'attached' });
    // Every example in the workspace opens and saves to the same program.
    const settled = () => page.waitForFunction(() => !/^(checking|opening)/.test(
      document.querySelector('[data-testid="ed-verdict"]').textContent), null, { timeout: 20000 });
    const openFile = async (name) => {
      await page.waitForFunction((n) => [...document.querySelectorAll('[data-testid="ed-files"] option')].some((o) => o.value === n), name);
      await page.selectOption('[data-testid="ed-files"]', name);
      await page.click('[data-testid="ed-open"]');
      await page.waitForFunction((n) => document.querySelector('[data-testid="ed-name"]').value === n, name);
      await settled();
    };
    const verdictOf = async () => (await identity()) || (await verdict()).replace(/[\w.-]+\.fbd:/g, 'F:');
    const examples = fs.readdirSync(ws).filter((f) => f.endsWith('.fbd') && !f.startsWith('copy-') && !f.startsWith('seed_copy')).sort();
    assert.ok(examples.length >= 10, 'the workspace holds ' + examples.length + ' examples');
    for (const name of examples) {
      await openFile(name);
      const before = await verdictOf();
      await page.fill('[data-testid="ed-name"]', 'copy-' + name);
      await page.click('[data-testid="ed-save"]');
      await page.waitForFunction((n) => document.querySelector('[data-testid="ed-saved"]').textContent.startsWith('saved ' + n), 'copy-' + name);
      await openFile('copy-' + name);
      assert.strictEqual(await verdictOf(), before, name + ': the saved copy is another program');
    }

    // The seed's PID loop from an empty page, with the mouse.
    await page.click('[data-testid="ed-new"]');
    const placeWithMouse = async (kind, col, row) => {
      await page.fill('[data-testid="ed-search"]', kind);
      await page.click(`[data-testid="palette-${kind}"]`);
      await cell(col, row);
      await page.click(`[data-testid="palette-${kind}"]`);  // disarm
    };
    const prop = async (testid, value) => {
      await page.fill(`[data-testid="${testid}"]`, value);
      await page.press(`[data-testid="${testid}"]`, 'Enter');
    };
    const select = (testid, opts) => page.click(`[data-testid="${testid}"]`, opts);
    await placeWithMouse('dai', 0, 0);
    await prop('prop-3', 'ProcVal');
    await placeWithMouse('asp', 1, 0);
    await prop('prop-2', '50');
    await prop('prop-3', 'Setpoint');
    await placeWithMouse('sub', 0, 1);
    await prop('prop-opt-0', '1');
    await placeWithMouse('epi', 0, 2);
    await prop('prop-1', '4');
    await prop('prop-2', '3');
    await placeWithMouse('deriv', 1, 2);   // the seed's spelling of derv
    await prop('prop-1', '1');
    await placeWithMouse('sub', 0, 3);
    await prop('prop-id', 'F7');
    await prop('prop-opt-0', '1');
    await placeWithMouse('dao', 0, 4);
    await prop('prop-4', 'ManiVal');
    for (const [from, to] of [['out-F2', 'pin-2-0'], ['out-F1', 'pin-2-1'], ['out-F3', 'pin-3-0'], ['out-F1', 'pin-4-0'],
      ['out-F4', 'pin-5-0'], ['out-F5', 'pin-5-1'], ['out-F7', 'pin-6-0']]) await drag(from, to);
    await compiles();
    // The four computing blocks become the macro PID(2|0|3): Kp, Ti and Td its
    // parameters, the subtractions' gains left as written.
    await select('block-F3');
    for (const b of ['block-F4', 'block-F5', 'block-F7']) await select(b, { modifiers: ['Shift'] });
    await page.click('[data-testid="ed-macro-new"]');
    await page.fill('[data-testid="ed-macro-name"]', 'PID');
    await page.uncheck('[data-testid="ed-macro-param-2-2"]');
    await page.uncheck('[data-testid="ed-macro-param-5-2"]');
    await page.click('[data-testid="ed-macro-make"]');
    await page.waitForSelector('[data-testid="block-F7"].g-macro');
    await select('block-F7');
    await prop('prop-id', 'F10');
    await compiles();
    assert.strictEqual(await identity(), original, 'the loop drawn with the mouse is not the seed\'s program:\n' + await page.evaluate(() => ed.verdict.text));
    await page.screenshot({ path: path.join(shots, 'editor-macro.png'), fullPage: true });
    // Open the macro: its formals on top, its four blocks, RETURN M7; then back.
    await page.dblclick('[data-testid="block-F10"]');
    for (const t of ['formal-M1', 'formal-M2', 'block-M3', 'block-M4', 'block-M5', 'block-M7']) await page.waitForSelector(`[data-testid="${t}"]`);
    assert.strictEqual(await page.inputValue('[data-testid="ed-return"]'), 'M7');
    await page.screenshot({ path: path.join(shots, 'editor-macro-open.png'), fullPage: true });
    await page.click('[data-testid="ed-back"]');
    // Expanding it gives back the same computation (another program: its
    // blocks are no longer named by the call), and undo brings the macro back.
    await select('block-F10');
    await page.click('[data-testid="prop-expand"]');
    await compiles();
    assert.notStrictEqual(await identity(), original);
    assert.ok(await page.$('[data-testid="block-F10"].g-macro') === null);
    await page.click('[data-testid="ed-undo"]');
    await compiles();
    assert.strictEqual(await identity(), original);

    // Simulate it: the same figures as rtplc sim prints, the plot, the CSV.
    await page.fill('[data-testid="ed-sim-plant"]', 'fopdt:K=2,T=4,L=0.5');
    await page.fill('[data-testid="ed-sim-duration"]', '40');
    await page.fill('[data-testid="ed-sim-steps"]', 'Setpoint=60@20');
    await page.click('[data-testid="ed-sim-run"]');
    await page.waitForFunction(() => /step at 20 s/.test(document.querySelector('[data-testid="ed-sim-figures"]').textContent), null, { timeout: 20000 });
    const figures = await page.textContent('[data-testid="ed-sim-figures"]');
    const cli = execFileSync(rtplc, ['sim', path.join(ws, 'seed_pid.fbd'), '--plant', 'fopdt:K=2,T=4,L=0.5', '--duration', '40', '--step', 'Setpoint=60@20'], { encoding: 'utf8' });
    assert.ok(cli.includes(figures), 'the page\'s figures are not what rtplc sim prints:\n' + figures + '\n---\n' + cli);
    await page.waitForSelector('[data-testid="sim-line-ProcVal"]', { state: 'attached' });
    await page.waitForFunction(() => Number(document.querySelector('[data-testid="ed-sim-plot"]').dataset.points) > 300);
    const [csv] = await Promise.all([page.waitForEvent('download'), page.click('[data-testid="ed-sim-csv"]')]);
    const csvText = fs.readFileSync(await csv.path(), 'utf8');
    assert.match(csvText.split('\n')[0], /^t,/);
    const cycles = await page.evaluate(() => ed.sim.cycles);
    assert.ok(cycles >= 400, cycles + ' cycles in 40 s at 0.1 s');
    assert.strictEqual(csvText.trim().split('\n').length, cycles + 1, 'the CSV has not one row per cycle');
    await page.screenshot({ path: path.join(shots, 'editor-sim.png'), fullPage: true });

    // Print: pages with the diagram and its title block, as PDF.
    await page.fill('[data-testid="ed-name"]', 'seed_pid.fbd');
    await page.evaluate(() => { window.print = () => { window.printed = true; }; });
    await page.click('[data-testid="ed-print"]');
    assert.ok(await page.evaluate(() => window.printed), 'print did not ask the browser to print');
    await page.emulateMedia({ media: 'print' });
    const pdf = path.join(shots, 'editor-print.pdf');
    await page.pdf({ path: pdf, preferCSSPageSize: true, printBackground: true });
    await page.emulateMedia({ media: 'screen' });
    const text = execFileSync('pdftotext', ['-layout', pdf, '-'], { encoding: 'utf8' });
    for (const want of [/seed_pid\.fbd/, /ProcVal/, /ManiVal/, /F10/, /PID/, /period\s+0\.1 s/, /program\s+[0-9a-f]{16} \(identity [0-9a-f]{16}\)/, /page\s+1 of 1/]) {
      assert.match(text, want, 'the PDF lacks ' + want);
    }
    execFileSync('pdftoppm', ['-png', '-r', '40', '-f', '1', '-l', '1', pdf, path.join(shots, 'editor-print')]);
    const png = fs.readdirSync(shots).find((f) => /^editor-print.*\.png$/.test(f));
    assert.ok(png && fs.statSync(path.join(shots, png)).size > 2000, 'pdftoppm drew no page');

    // With the keyboard only: the same loop again, from an empty page.
    await page.focus('[data-testid="ed-new"]');
    await page.keyboard.press('Enter');
    await page.focus('[data-testid="ed-sheet"]');
    const pos = { col: 0, row: 0 };
    const go = async (col, row) => {
      while (pos.col < col) { await key('ArrowRight'); pos.col++; }
      while (pos.col > col) { await key('ArrowLeft'); pos.col--; }
      while (pos.row < row) { await key('ArrowDown'); pos.row++; }
      while (pos.row > row) { await key('ArrowUp'); pos.row--; }
    };
    const typeKeys = async (t) => { await key('Control+A'); await page.keyboard.type(t); await key('Enter'); };
    const tabs = async (n) => { for (let k = 0; k < n; ++k) await key('Tab'); };
    const placeWithKeys = async (kind, col, row) => {
      await go(col, row);
      await key('/');
      await page.keyboard.type(kind);
      await key('Enter');   // arms it, back on the sheet
      await key('Enter');   // places it under the cursor
    };
    await placeWithKeys('dai', 0, 0);
    await key('p'); await tabs(4); await typeKeys('ProcVal'); await key('Escape');
    await placeWithKeys('asp', 1, 0);
    await key('p'); await tabs(3); await typeKeys('50'); await tabs(1); await typeKeys('Setpoint'); await key('Escape');
    await placeWithKeys('sub', 0, 1);
    await key('p'); await tabs(3); await typeKeys('1'); await key('Escape');
    await placeWithKeys('epi', 0, 2);
    await key('p'); await tabs(2); await typeKeys('4'); await tabs(1); await typeKeys('3'); await key('Escape');
    await placeWithKeys('deriv', 1, 2);   // the seed's spelling finds derv
    await key('p'); await tabs(2); await typeKeys('1'); await key('Escape');
    await placeWithKeys('sub', 0, 3);
    await key('p'); await typeKeys('F7'); await tabs(3); await typeKeys('1'); await key('Escape');
    await placeWithKeys('dao', 0, 4);
    await key('p'); await tabs(4); await typeKeys('ManiVal'); await key('Escape');
    await key('Escape');  // disarm
    for (const [a, b] of [[[1, 0], [0, 1]], [[0, 0], [0, 1]], [[0, 1], [0, 2]], [[0, 0], [1, 2]], [[0, 2], [0, 3]], [[1, 2], [0, 3]], [[0, 3], [0, 4]]]) {
      await go(...a); await key('Insert'); await go(...b); await key('Insert');
    }
    await compiles();
    for (const c of [[0, 1], [0, 2], [1, 2], [0, 3]]) { await go(...c); await key(' '); }
    await key('m');
    await typeKeys('PID');
    await page.waitForSelector('[data-testid="ed-macro-form"]:not([hidden])');  // Enter in the name does not make it
    await key('Tab'); await key(' ');           // sub F3's gain stays written
    await tabs(4); await key(' ');              // sub F7's too
    await key('Tab'); await key('Enter');       // make the macro
    await page.waitForSelector('[data-testid="block-F7"].g-macro');
    await go(0, 3);
    await key('Enter');
    await key('p'); await typeKeys('F10'); await key('Escape');
    await compiles();
    assert.strictEqual(await identity(), original, 'the loop built with the keys is not the seed\'s program');

    // Online: the running seed loop, ProcVal live on its wire; Kp 4 -> 8 swapped
    // in after the migration report, the loop answering; then rolled back.
    await page.click('[data-testid="ed-task-refresh"]');
    await page.waitForFunction(() => [...document.querySelectorAll('[data-testid="ed-task"] option')].some((o) => o.value === 'seed_pid'));
    await page.selectOption('[data-testid="ed-task"]', 'seed_pid');
    await page.click('[data-testid="ed-open-running"]');
    await page.waitForSelector('[data-testid="live-F1"]');
    const liveNumber = (id) => page.evaluate((t) => parseFloat(document.querySelector(`[data-testid="live-${t}"]`).textContent), id);
    await page.waitForFunction(() => /^-?[0-9.e+-]+ good$/.test(document.querySelector('[data-testid="live-F1"]').textContent), null, { timeout: 15000 });
    const pv0 = await liveNumber('F1');
    await page.waitForFunction((v) => parseFloat(document.querySelector('[data-testid="live-F1"]').textContent) !== v, pv0, { timeout: 15000 });
    // Inside the macro, the call's own blocks (F10.M4, ...) from the task's watch.
    await page.dblclick('[data-testid="block-F10"]');
    await page.waitForFunction(() => /^-?[0-9.e+-]+ good$/.test((document.querySelector('[data-testid="live-M4"]') || {}).textContent || ''), null, { timeout: 15000 });
    await page.screenshot({ path: path.join(shots, 'editor-online-macro.png'), fullPage: true });
    await page.click('[data-testid="ed-back"]');
    await page.screenshot({ path: path.join(shots, 'editor-online.png'), fullPage: true });
    await select('block-F10');
    await prop('prop-2', '8');
    await compiles();
    const edited = await page.evaluate(() => ed.verdict.program_hash);
    await page.click('[data-testid="ed-swap-check"]');
    await page.waitForFunction(() => /kept state/.test(document.querySelector('[data-testid="ed-swap-report"]').textContent), null, { timeout: 15000 });
    await page.screenshot({ path: path.join(shots, 'editor-swap.png'), fullPage: true });
    const mv0 = await liveNumber('F10');
    await page.click('[data-testid="ed-swap-confirm"]');
    await page.waitForFunction(() => /^swapped/.test(document.querySelector('[data-testid="ed-online-said"]').textContent), null, { timeout: 15000 });
    const running = await page.evaluate(async () => (await (await fetch('/api/program?task=seed_pid')).json()).result.running);
    assert.strictEqual(running, edited, 'the task does not run the edited program');
    // The swap is bumpless (the integral keeps the output where it was); the
    // loop with its new gain answers a set-point step, seen on its wires.
    const set = (v) => page.evaluate((x) => call('POST', '/api/set', { label: 'Setpoint', value: x }), v);
    assert.strictEqual((await set(60)).status, 200);
    await page.waitForFunction((v) => Math.abs(parseFloat(document.querySelector('[data-testid="live-F10"]').textContent) - v) > 5, mv0, { timeout: 15000 });
    await page.waitForFunction(() => parseFloat(document.querySelector('[data-testid="live-F1"]').textContent) > 55, null, { timeout: 20000 });
    assert.match(await page.textContent('[data-testid="live-F2"]'), /^60 /);
    await set(50);
    page.once('dialog', (d) => d.accept());
    await page.click('[data-testid="ed-rollback"]');
    await page.waitForFunction(() => /^rolled back/.test(document.querySelector('[data-testid="ed-online-said"]').textContent), null, { timeout: 15000 });
    const back = await page.evaluate(async () => (await (await fetch('/api/program?task=seed_pid')).json()).result.running);
    assert.notStrictEqual(back, edited, 'rollback left the edited program running');
    await page.click('[data-testid="ed-offline"]');

    // SFC and PLCopen open read-only: the chart's steps; the project's POUs and
    // FBD elements; the running SFC task online with its active step lit.
    await openFile('tank.sfc');
    await page.waitForSelector('[data-testid="ed-readonly"] [data-testid="step-S0"]');
    assert.match(await verdict(), /SFC chart .* \(read-only\)/);
    await openFile('plcopen_tank.xml');
    await page.waitForSelector('[data-testid="pou-main"] [data-testid="el-main-2"]');
    await page.waitForSelector('[data-testid="pou-Hysteresis"] pre');
    await page.screenshot({ path: path.join(shots, 'editor-plcopen.png'), fullPage: true });
    await page.selectOption('[data-testid="ed-task"]', 'sequence');
    await page.click('[data-testid="ed-open-running"]');
    await page.waitForSelector('[data-testid="ed-readonly"] .step.active', { timeout: 15000 });
    await page.screenshot({ path: path.join(shots, 'editor-sfc-online.png'), fullPage: true });
    await page.click('[data-testid="ed-offline"]');
    await openFile('seed_pid.fbd');
    await page.waitForSelector('[data-testid="ed-sheet"]', { state: 'visible' });
    assert.deepStrictEqual(errors, [], 'the page threw: ' + errors.join('; '));
    console.log('OK: editor: open, check, save a copy with the same identity, an error on its block, undo/redo, draw with the mouse and with the keys; every example round-trips; the seed PID loop built with the mouse and with the keys (macro from a selection), simulated, printed to PDF, opened online, swapped and rolled back; SFC and PLCopen read-only, an SFC task live');
  } catch (e) {
    await page.screenshot({ path: path.join(shots, 'editor-failure.png'), fullPage: true }).catch(() => {});
    console.error('FAILED:', e.message, '\n', await page.textContent('[data-testid="ed-verdict"]').catch(() => ''));
    process.exitCode = 1;
  } finally {
    await browser.close();
    fs.rmSync(userDir, { recursive: true, force: true });
  }
})();
