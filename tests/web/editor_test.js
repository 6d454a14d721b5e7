// Drives the FBD editor page in Debian's chromium (headless) through
// playwright-core: an engineer logs in, opens the seed's PID loop from the
// workspace (drawn on the seed's grid, checked by the compiler), saves a copy
// that opens to the same program identity, draws an error and sees it on the
// block, undoes and redoes it, and builds a small loop with the mouse and
// again with the keyboard only (arrows, Enter, Ins) that compiles.
// Usage: node editor_test.js BASE_URL USER PASSWORD SHOTS_DIR WORKSPACE
'use strict';
const assert = require('assert');
const fs = require('fs');
const path = require('path');
const { chromium } = require('playwright-core');

const [base, user, password, shots, ws] = process.argv.slice(2);

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
    assert.deepStrictEqual(errors, [], 'the page threw: ' + errors.join('; '));
    console.log('OK: editor: open, check, save a copy with the same identity, an error on its block, undo/redo, draw with the mouse and with the keys');
  } catch (e) {
    await page.screenshot({ path: path.join(shots, 'editor-failure.png'), fullPage: true }).catch(() => {});
    console.error('FAILED:', e.message, '\n', await page.textContent('[data-testid="ed-verdict"]').catch(() => ''));
    process.exitCode = 1;
  } finally {
    await browser.close();
    fs.rmSync(userDir, { recursive: true, force: true });
  }
})();
