// Drives the web console in Debian's chromium (headless) through playwright-core:
// the one-time link logs in; ProcVal moves; a set-point set in the form is the
// runtime's (the loop follows); force shows the FORCED banner and unforce
// clears it; a swap is checked (errors, or the migration report) before it is
// confirmed, the program store lists it and rollback undoes it; the SFC view
// lights the active step; a Modbus slave that dies turns its channels bad; a
// runtime that dies is shown STALE. Screenshots go to SHOTS.
// Usage: node browser_test.js LINK SHOTS_DIR RUN_PID_FILE DIR   (tests/web/browser_test.sh runs it)
'use strict';
const assert = require('assert');
const fs = require('fs');
const path = require('path');
const { chromium } = require('playwright-core');

const [link, shots, pidFile, dir] = process.argv.slice(2);
const result = (page, re) => page.waitForFunction((src) => new RegExp(src).test(
  document.querySelector('[data-testid="op-result"]').textContent), re.source, { timeout: 20000 });

async function value(page, label) {
  const t = await page.textContent(`[data-testid="value-${label}"]`);
  return Number(t);
}

(async () => {
  fs.mkdirSync(shots, { recursive: true });
  const userDir = fs.mkdtempSync(path.join(require('os').tmpdir(), 'rtplc-chromium-'));
  const browser = await chromium.launchPersistentContext(userDir, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
      '--disable-component-update', '--disable-sync'],
    viewport: { width: 1280, height: 900 },
    acceptDownloads: true,
    bypassCSP: true,  // the page's own code obeys the CSP; the test's probes (waitForFunction) evaluate strings
  });
  const page = browser.pages()[0] || await browser.newPage();
  page.on('dialog', (d) => d.accept());
  try {
    await page.goto(link);
    await page.waitForSelector('[data-testid="value-ProcVal"]');
    await page.waitForFunction(() => document.querySelector('[data-testid="run-state"]').textContent === 'RUN');
    assert.match(await page.textContent('[data-testid="who"]'), /\(admin\)$/);
    // ProcVal moves: two readings a second apart differ.
    await page.waitForTimeout(300);
    const a = await value(page, 'ProcVal');
    await page.waitForTimeout(1000);
    const b = await value(page, 'ProcVal');
    assert.notStrictEqual(a, b, 'ProcVal does not move in the console');
    assert.strictEqual(await page.textContent('[data-testid="quality-ProcVal"]'), 'good');
    await page.screenshot({ path: path.join(shots, 'overview.png'), fullPage: true });
    // Only what is shown is streamed: a search narrows the stream to its rows,
    // which still move; clearing it brings every channel back.
    await page.fill('#search', 'ProcVal');
    await page.waitForFunction(() => JSON.stringify(liveWants) === '["ProcVal"]');
    const c = await value(page, 'ProcVal');
    await page.waitForFunction((was) => Number(document.querySelector('[data-testid="value-ProcVal"]').textContent) !== was, c);
    await page.fill('#search', '');
    await page.waitForFunction(() => liveWants === null);
    // HMI variables (an ST panel's HMI_REAL): marked in the table, found by "hmi",
    // set like any set-point; the one the program writes shows what it computed.
    await page.fill('#search', 'hmi');
    await page.waitForFunction(() => JSON.stringify(liveWants) === '["Panel.speed","Panel.doubled"]' ||
                                     JSON.stringify(liveWants) === '["Panel.doubled","Panel.speed"]');
    assert.match(await page.textContent('[data-testid="channel-Panel.speed"]'), /setpoint \(HMI\)/);
    assert.match(await page.textContent('[data-testid="channel-Panel.doubled"]'), /output \(HMI\)/);
    await page.waitForFunction(() => Number(document.querySelector('[data-testid="value-Panel.doubled"]').textContent) === 5);
    assert.strictEqual(await page.textContent('[data-testid="quality-Panel.doubled"]'), 'good');
    await page.fill('#search', '');
    await page.waitForFunction(() => liveWants === null);

    // Set the set-point; the value in the table and the loop follow.
    await page.click('[data-testid="nav-operations"]');
    await page.selectOption('[data-testid="set-label"]', 'Setpoint');
    await page.fill('[data-testid="set-value"]', '70');
    await page.click('[data-testid="set-submit"]');
    await page.waitForFunction(() => /Setpoint = 70 \(was /.test(document.querySelector('[data-testid="op-result"]').textContent));
    // A value outside the limits is refused with the runtime's reason.
    await page.fill('[data-testid="set-value"]', '150');
    await page.click('[data-testid="set-submit"]');
    await page.waitForFunction(() => /outside the range/.test(document.querySelector('[data-testid="op-result"]').textContent));
    await page.screenshot({ path: path.join(shots, 'operations.png'), fullPage: true });
    await page.selectOption('[data-testid="set-label"]', 'Panel.speed');
    await page.fill('[data-testid="set-value"]', '4');
    await page.click('[data-testid="set-submit"]');
    await page.waitForFunction(() => /Panel.speed = 4 \(was /.test(document.querySelector('[data-testid="op-result"]').textContent));
    await page.click('[data-testid="nav-overview"]');
    await page.waitForFunction(() => Number(document.querySelector('[data-testid="value-Panel.doubled"]').textContent) === 8);
    await page.waitForFunction(() => Number(document.querySelector('[data-testid="value-Setpoint"]').textContent) === 70);
    await page.waitForFunction(() => Number(document.querySelector('[data-testid="value-ProcVal"]').textContent) > 60,
      null, { timeout: 20000 });

    // Force and unforce, with the banner.
    await page.click('[data-testid="nav-operations"]');
    await page.selectOption('[data-testid="force-label"]', 'ManiVal');
    await page.fill('[data-testid="force-value"]', '12.5');
    await page.click('[data-testid="force-submit"]');
    await page.waitForSelector('[data-testid="forced-banner"]:not([hidden])');
    assert.match(await page.textContent('[data-testid="forced-banner"]'), /ManiVal = 12\.5/);
    await page.click('[data-testid="nav-overview"]');
    await page.waitForFunction(() => document.querySelector('[data-testid="quality-ManiVal"]').textContent === 'FORCED');
    await page.screenshot({ path: path.join(shots, 'forced.png'), fullPage: true });
    await page.click('[data-testid="nav-operations"]');
    await page.click('[data-testid="unforce-submit"]');
    await page.waitForSelector('[data-testid="forced-banner"]', { state: 'hidden' });

    // Swap: a program with errors is refused at the check, with file:line:col, and cannot be confirmed.
    await page.selectOption('[data-testid="swap-task"]', 'seed_pid');
    await page.setInputFiles('[data-testid="swap-file"]', path.join(dir, 'bad.fbd'));
    await page.click('[data-testid="swap-submit"]');
    await result(page, /would not swap, the program has errors:\n(.|\n)*bad\.fbd:8:6: error/);
    assert.ok(await page.isHidden('[data-testid="swap-confirm"]'), 'a program with errors can be confirmed');
    // A good one: the check reports what it keeps, then the operator confirms.
    await page.setInputFiles('[data-testid="swap-file"]', path.join(dir, 'seed_pid_v2.fbd'));
    await page.click('[data-testid="swap-submit"]');
    await result(page, /compiles and verifies(.|\n)*kept state: \d+(.|\n)*nothing was changed/);
    await page.screenshot({ path: path.join(shots, 'swap-check.png'), fullPage: true });
    await page.click('[data-testid="swap-confirm"]');
    await result(page, /now running seed_pid_v2\.fbd(.|\n)*kept for restarts as program/);
    await page.waitForFunction(() => document.querySelectorAll('[data-testid="programs"] tbody tr').length === 2);
    assert.match(await page.textContent('[data-testid="programs"] tbody tr'), /\(running\).*swap seed_pid_v2\.fbd/);
    await page.click('[data-testid="programs"] tbody tr:first-child button');
    await page.waitForSelector('[data-testid="program-source"]:not([hidden])');
    assert.strictEqual(await page.textContent('[data-testid="program-source"]'), fs.readFileSync(path.join(dir, 'seed_pid_v2.fbd'), 'utf8'));
    await page.screenshot({ path: path.join(shots, 'programs.png'), fullPage: true });
    await page.click('[data-testid="rollback-submit"]');
    await result(page, /now running .*seed_pid\.fbd/);
    await page.waitForFunction(() => document.querySelectorAll('[data-testid="programs"] tbody tr').length === 1);

    // The SFC view: the tank's chart with its initial step active.
    await page.click('[data-testid="nav-chart"]');
    await page.waitForSelector('[data-testid="step-S0"].active');
    assert.match(await page.textContent('[data-testid="chart-info"]'), /chart tank, .* 7 steps, 7 transitions/);
    assert.match(await page.textContent('[data-testid="chart"]'), /t0: PBS AND LS2/);
    assert.ok(!(await page.getAttribute('[data-testid="step-S1"]', 'class')).includes('active'));
    await page.screenshot({ path: path.join(shots, 'chart.png'), fullPage: true });

    // The Variables page: the ST panel's variables, a STRING as its text.
    await page.click('[data-testid="nav-variables"]');
    await page.selectOption('[data-testid="vars-task"]', 'panel');
    await page.waitForFunction(() => {
      const r = document.querySelector('[data-testid="var-Panel.shown"]');
      // (Panel.speed was set to 4 above: REAL_TO_STRING writes '4')
      return r && r.children[1].textContent === "'speed 4'" && r.children[2].textContent === 'good';
    }, null, { timeout: 20000 });
    // Only the program's variables: none of the compiler's temporaries (scopy.$5, k:2, plcopen.true).
    const names = await page.$$eval('[data-testid="vars"] tbody tr', (rows) => rows.map((r) => r.children[0].textContent));
    assert.ok(names.includes('Panel.shown') && names.includes('Panel.doubled'), names.join(' '));  // (speed is a set-point: a channel, on the Overview)
    assert.ok(names.every((n) => !/[$@:]/.test(n) && !n.startsWith('plcopen.')), names.join(' '));
    await page.screenshot({ path: path.join(shots, 'variables.png'), fullPage: true });

    // The Modbus slave dies: its channel turns bad (or stale), never stays good.
    await page.click('[data-testid="nav-overview"]');
    await page.waitForFunction(() => document.querySelector('[data-testid="quality-FieldLevel"]').textContent === 'good' &&
      Number(document.querySelector('[data-testid="value-FieldLevel"]').textContent) === 21.5, null, { timeout: 20000 });
    process.kill(Number(fs.readFileSync(path.join(dir, 'slave.pid'), 'utf8')), 'SIGKILL');
    await page.waitForFunction(() => /^(bad|stale)$/.test(document.querySelector('[data-testid="quality-FieldLevel"]').textContent) &&
      /^(bad|stale)$/.test(document.querySelector('[data-testid="quality-FieldEcho"]').textContent), null, { timeout: 20000 });
    await page.screenshot({ path: path.join(shots, 'slave-dead.png'), fullPage: true });

    // A trend of two channels: every cycle arrives, none lost, and the CSV has them.
    await page.click('[data-testid="nav-trend"]');
    await page.selectOption('[data-testid="trend-labels"]', ['ProcVal', 'Setpoint']);
    await page.click('[data-testid="trend-start"]');
    await page.waitForFunction(() => /: (\d+) cycles, none lost/.test(document.querySelector('[data-testid="trend-info"]').textContent) &&
      Number(/: (\d+) cycles/.exec(document.querySelector('[data-testid="trend-info"]').textContent)[1]) >= 20, null, { timeout: 15000 });
    await page.screenshot({ path: path.join(shots, 'trend.png'), fullPage: true });
    const [download] = await Promise.all([page.waitForEvent('download'), page.click('[data-testid="trend-csv"]')]);
    const csv = fs.readFileSync(await download.path(), 'utf8').trim().split('\n');
    assert.strictEqual(csv[1], 't_s,cycle,record,ProcVal,Setpoint');
    const recs = csv.slice(2).map((l) => Number(l.split(',')[2]));
    assert.ok(recs.length >= 20, 'the CSV has ' + recs.length + ' rows');
    for (let i = 1; i < recs.length; i++) assert.strictEqual(recs[i], recs[i - 1] + 1, 'records are consecutive');
    await page.click('[data-testid="trend-stop"]');

    // The jitter page draws each task's histograms.
    await page.click('[data-testid="nav-jitter"]');
    await page.waitForSelector('[data-testid="jitter-wake-seed_pid"] svg rect');
    assert.match(await page.textContent('[data-testid="jitter-wake-seed_pid"] h3'), /wake latency: \d+ cycles, p50 /);
    await page.screenshot({ path: path.join(shots, 'jitter.png'), fullPage: true });

    // The audit page names the console's user.
    await page.click('[data-testid="nav-audit"]');
    await page.waitForFunction(() => /web \S+ \[admin\] set label=Setpoint value=70/.test(document.querySelector('[data-testid="audit"]').textContent));
    await page.screenshot({ path: path.join(shots, 'audit.png'), fullPage: true });

    // The runtime dies: the console says STALE.
    await page.click('[data-testid="nav-overview"]');
    process.kill(Number(fs.readFileSync(pidFile, 'utf8')), 'SIGKILL');
    await page.waitForSelector('[data-testid="stale-banner"]:not([hidden])', { timeout: 15000 });
    assert.strictEqual(await page.textContent('[data-testid="run-state"]'), 'STALE');
    await page.screenshot({ path: path.join(shots, 'stale.png'), fullPage: true });
    console.log('OK: log in, live values, set, limits, force/unforce, swap check/confirm, program store, rollback, SFC view, dead Modbus slave, trend, jitter, audit, stale: all seen in chromium');
  } catch (e) {
    await page.screenshot({ path: path.join(shots, 'failure.png'), fullPage: true }).catch(() => {});
    console.error('FAILED: ' + (e && e.stack || e));
    process.exitCode = 1;
  } finally {
    await browser.close();
    fs.rmSync(userDir, { recursive: true, force: true });
  }
})();
